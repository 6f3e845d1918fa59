"""Tests for mtmetrology.export.fanuc (pitch-error compensation, parameters 3620–3627)."""

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.export import fanuc
from mtmetrology.export.emulation import fanuc as fanuc_control
from mtmetrology.export.model import compensation_model
from mtmetrology.export.workflow import export_compensation
from mtmetrology.kinematics import Machine

ROTARY_MACHINE = """kind: machine
version: 1
name: rotary-test
topology: WCXFYZT
axes:
  X: {travel_mm: [0, 400]}
  Y: {travel_mm: [0, 300]}
  Z: {travel_mm: [0, 200]}
  C: {travel_deg: [0, 360]}
error_models:
  m:
    basis: monomial
    motions:
      E_CC: [1, 2]
"""


def test_fanuc_increments_sum_to_the_absolute_table(make_set):
    m = Machine.load("three-axis-xfyz")
    values = np.random.default_rng(4).normal(0.0, 5.0, m.n_params)
    ps = make_set(m, dict(zip(m.parameter_names, values, strict=True)))
    cm = compensation_model(m, ps, pitch=20)
    tables = fanuc.build(cm)
    text = fanuc.render(tables, cm)["fanuc_pitch.txt"]
    increments = [int(line.split()[1][1:]) for line in text.splitlines() if line.startswith("N")]
    start = 0
    for t in tables:
        inc = np.array(increments[start : start + t.positions.size])
        absolute = np.round(t.forward / 1e-3).astype(int)  # detection unit 1 µm
        np.testing.assert_array_equal(np.cumsum(inc) - inc[0], absolute - absolute[0])
        assert absolute[t.reference_index] == 0
        start += t.positions.size


def test_fanuc_rotary_increments_sum_to_zero_and_a_non_periodic_table_is_refused(
    make_set, tmp_path
):
    """E_CC(c) = c1 c + c2 c² with c2 = −c1/(2π) is periodic over 360°: the increments of
    one revolution sum to zero; with c2 = 0 they cannot and the control would refuse it."""
    path = tmp_path / "rotary.yaml"
    path.write_text(ROTARY_MACHINE)
    m = Machine.load(path)
    c1 = 1000.0
    ps = make_set(m, {"E_CC1": c1, "E_CC2": -c1 / (2 * np.pi)})
    cm = compensation_model(m, ps, pitch=45)
    (table,) = fanuc.build(cm, ["E_CC"])
    text = fanuc.render([table], cm)["fanuc_pitch.txt"]
    inc = [int(line.split()[1][1:]) for line in text.splitlines() if line.startswith("N")]
    assert len(inc) == 9 and sum(inc[1:]) == 0 and max(np.abs(inc)) > 30
    assert inc[0] == inc[-1]  # the reference point takes the value of the last (p. 100)
    assert "3625 C 360000" in text.splitlines()
    bad = compensation_model(m, make_set(m, {"E_CC1": c1}), pitch=45)
    with pytest.raises(InputError, match=r"sum to .* not zero"):
        fanuc.build(bad, ["E_CC"])


def test_fanuc_states_the_correction_left_to_the_reference_position(make_set):
    """Five-axis preset, E_XX1 = +100 µm/m, reference X = −100 mm: the table is zero there
    and the note gives the correction −E_XX(−100 mm) = +10 µm."""
    m = Machine.load("five-axis-wcbxfzyst")
    ps = make_set(m, {"E_XX1": 100.0})
    result = export_compensation(
        m, ps, "fanuc", pitch=10, functions=["E_XX"], reference={"X": -100.0}
    )
    assert result.sign["established"] is False  # stated first, in words
    sign, note = result.notes
    assert sign == result.sign["statement"]
    assert note.startswith("E_XX: the correction at the reference position X = -100 mm (+10 µm)")


def test_fanuc_bidirectional_parameters_closed_form(reversal_machine, make_set):
    """E_XX = 100 µm/m · x + 3 µm · sense: corrections −E differ by 2 · 3 µm between the
    directions, so 3627 (negative-direction value at the reference) is +6 units (1 µm),
    the negative table follows the positive one from 3626, and the file read back gives
    the same two tables."""
    machine = reversal_machine
    ps = make_set(machine, {"E_XX1": 100.0, "E_XXb": 3.0})
    cm = compensation_model(machine, ps, pitch=20)
    tables = fanuc.build(cm, ["E_XX"])
    files = fanuc.render(tables, cm)
    params = {
        line.split()[0]: int(line.split()[2])
        for line in files["fanuc_pitch.txt"].splitlines()
        if line[:1].isdigit()
    }
    assert params["3605#0"] == 1
    assert params["3626"] == params["3622"] + 1  # 21 points each: 0–20, 21–41
    assert params["3627"] == 6
    (back,) = fanuc_control.load(files, cm.reference)
    np.testing.assert_array_equal(back.forward, tables[0].forward)
    np.testing.assert_array_equal(back.reverse, tables[0].reverse)
    np.testing.assert_allclose(back.reverse - back.forward, 6e-3, atol=1e-12)
    # without a reversal term nothing of the bidirectional function is written
    one = fanuc.render(
        fanuc.build(compensation_model(machine, make_set(machine, {}), pitch=20)), cm
    )
    assert "3605#0" not in one["fanuc_pitch.txt"]


def test_increments_are_differences_and_their_running_sum_gives_the_table_back():
    absolute = np.array([3, 5, 4, 4, -2])
    inc = fanuc.increments(absolute)
    np.testing.assert_array_equal(inc, [0, 2, -1, 0, -6])
    np.testing.assert_array_equal(np.cumsum(inc), absolute - absolute[0])


@pytest.mark.parametrize(("magnification", "step"), [(1, -10), (10, -1)])
def test_magnification_divides_the_data_and_reads_back(make_set, magnification, step):
    """E_XX1 = 100 µm over the X travel of 400 mm: 10 µm per 20 mm interval, corrected by
    −10 detection units of 1 µm, or −1 unit of 10 µm with 3623 = 10."""
    m = Machine.load("three-axis-xfyz")
    cm = compensation_model(m, make_set(m, {"E_XX1": 100.0}), pitch=20)
    tables = fanuc.build(cm, ["E_XX"], magnification=magnification)
    text = fanuc.render(tables, cm, magnification=magnification)["fanuc_pitch.txt"]
    lines = text.splitlines()
    assert f"3623 X {magnification}" in lines and "3624 X 20000" in lines
    inc = [int(line.split()[1][1:]) for line in lines if line.startswith("N")]
    assert inc == [0] + [step] * 20
    (back,) = fanuc_control.load({"fanuc_pitch.txt": text}, cm.reference)
    np.testing.assert_allclose(back.forward, tables[0].forward, atol=1e-12)
    np.testing.assert_allclose(back.positions, tables[0].positions, atol=1e-9)


@pytest.mark.parametrize("magnification", [0, 101, 2.0])
def test_magnification_outside_1_to_100_is_refused(make_set, magnification):
    m = Machine.load("three-axis-xfyz")
    cm = compensation_model(m, make_set(m, {"E_XX1": 100.0}), pitch=20)
    with pytest.raises(InputError) as info:
        fanuc.build(cm, magnification=magnification)
    assert str(info.value) == f"3623 magnification: {magnification!r} must be an integer 1–100"


def test_more_than_1024_points_are_refused(make_set):
    m = Machine.load("three-axis-xfyz")
    cm = compensation_model(m, make_set(m, {"E_XX1": 100.0}), pitch=0.5)
    with pytest.raises(InputError) as info:
        fanuc.build(cm)
    assert str(info.value) == (
        "E_YY: 1602 compensation points over all axes; format fanuc accepts at most 1024 "
        "(numbers 0–1023); choose a larger pitch"
    )


def test_parse_names_the_bad_line_and_the_missing_point(make_set):
    m = Machine.load("three-axis-xfyz")
    cm = compensation_model(m, make_set(m, {"E_XX1": 100.0}), pitch=20)
    text = fanuc.render(fanuc.build(cm, ["E_XX"]), cm)["fanuc_pitch.txt"]
    lines = text.splitlines()
    k = next(i for i, line in enumerate(lines) if line.startswith("N10003"))
    bad = lines.copy()
    bad[k] = "N10003 Px"
    with pytest.raises(InputError) as info:
        fanuc_control.load({"fanuc_pitch.txt": "\n".join(bad)}, cm.reference)
    assert str(info.value) == f"fanuc_pitch.txt, line {k + 1}: cannot read 'N10003 Px'"
    with pytest.raises(InputError) as info:
        fanuc_control.load({"fanuc_pitch.txt": "\n".join(lines[:k] + lines[k + 1 :])}, cm.reference)
    assert str(info.value) == "fanuc_pitch.txt: axis X: no value for point 3"
