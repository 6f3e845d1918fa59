"""The neutral ISO 230-2 CSV: a written test reads back exactly; bad input is refused with
one line naming the file and the line, field, run or target."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.positioning.data import Conditions, PositioningTest, read_test


def _test(m=4, n=5):
    rng = np.random.default_rng(0)
    targets = np.array([0.0, 210.5, 395.0, 600.0])[:m]
    cond = Conditions(axis="Y", travel_mm=[0.0, 600.0], air_temperature_C=21.5)
    return PositioningTest(targets, rng.normal(0, 0.002, (m, n, 2)), cond, "t")


def _lines(tmp_path, test=None):
    path = tmp_path / "t.csv"
    (test or _test()).write(path)
    return path, path.read_text().splitlines()


def test_write_then_read_is_the_same_test(tmp_path):
    t = _test()
    path, _ = _lines(tmp_path, t)
    back = read_test(path)
    np.testing.assert_array_equal(back.targets, t.targets)
    np.testing.assert_allclose(back.deviations, t.deviations, rtol=0, atol=1e-9)
    assert back.conditions == t.conditions


def test_default_conditions_read_back(tmp_path):
    t = PositioningTest(np.array([0.0, 100.0]), np.zeros((2, 5, 2)))
    path, _ = _lines(tmp_path, t)
    assert read_test(path).conditions == Conditions()


def test_a_conditions_file_wins_over_the_header(tmp_path):
    path, _ = _lines(tmp_path)
    cond = tmp_path / "c.yaml"
    cond.write_text("kind: iso230-2-conditions\nversion: 1\naxis: z\nair_pressure_Pa: 95000\n")
    back = read_test(path, cond)
    assert (back.conditions.axis, back.conditions.air_pressure_Pa) == ("Z", 95000.0)


def _refused(tmp_path, lines):
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError) as err:
        read_test(path)
    message = str(err.value)
    assert "\n" not in message and message.startswith(str(path))
    return message


def _body(lines):
    head = next(k for k, line in enumerate(lines) if line.startswith("target,"))
    return lines[: head + 1], lines[head + 1 :]


def test_a_run_missing_a_direction_is_refused(tmp_path):
    _, lines = _lines(tmp_path)
    head, body = _body(lines)
    body = [b for b in body if not (b.split(",")[2] == "3" and b.split(",")[3] == "-")]
    assert _refused(tmp_path, head + body).endswith("run 3 has no readings in direction -")


def test_fewer_than_five_runs_is_refused(tmp_path):
    _, lines = _lines(tmp_path)
    head, body = _body(lines)
    body = [b for b in body if b.split(",")[2] != "5"]
    assert "4 runs per direction; ISO 230-2 requires 5" in _refused(tmp_path, head + body)


def test_non_monotonic_targets_are_refused(tmp_path):
    _, lines = _lines(tmp_path)
    head, body = _body(lines)
    body = [b.replace(",395.000000,", ",100.000000,") for b in body]
    msg = _refused(tmp_path, head + body)
    assert "targets not monotonic: target 3 at 100 mm after target 2 at 210.5 mm" in msg


def test_a_missing_target_is_refused(tmp_path):
    _, lines = _lines(tmp_path)
    head, body = _body(lines)
    body = [b for b in body if not b.startswith("2,")]
    assert _refused(tmp_path, head + body).endswith(
        "target 2 missing (targets are numbered 1 to m)"
    )


def test_a_target_missing_from_one_run_is_refused(tmp_path):
    _, lines = _lines(tmp_path)
    head, body = _body(lines)
    body = [b for b in body if not b.startswith("3,395.000000,2,+")]
    assert _refused(tmp_path, head + body).endswith("run 2, direction +: target 3 missing")


def test_a_bad_field_names_its_line(tmp_path):
    _, lines = _lines(tmp_path)
    head, body = _body(lines)
    body[4] = body[4].rsplit(",", 1)[0] + ",abc"
    line = len(head) + 5
    assert _refused(tmp_path, head + body).endswith(
        f"line {line}: field 'deviation_um': 'abc' is not a number"
    )


def test_an_unknown_direction_and_a_missing_column_are_refused(tmp_path):
    _, lines = _lines(tmp_path)
    head, body = _body(lines)
    body[0] = body[0].replace(",+,", ",up-ish,")
    assert "field 'direction'" in _refused(tmp_path, head + body)
    assert "column 'direction' missing" in _refused(
        tmp_path, [head[-1].replace("direction", "dir"), *body]
    )


def test_a_bad_condition_is_refused(tmp_path):
    _, lines = _lines(tmp_path)
    lines = ["# humidity_percent: wet" if line.startswith("# humidity") else line for line in lines]
    assert _refused(tmp_path, lines).endswith("humidity_percent: 'wet' is not a finite number")
