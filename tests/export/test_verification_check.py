"""The comparison of readings taken on the machine with the predicted residual (issue 29):
readings simulated from the prediction of each case (correct table, sign flipped, table not
applied, half the table) plus noise give that case's verdict; a correct table is confirmed
at the stated rate; bad files are refused naming file, line and column."""

from __future__ import annotations

import csv
import io

import numpy as np
import pytest

from mtmetrology.export.verification import TEMPLATE
from mtmetrology.export.verification_check import compare_readings
from mtmetrology.io.files import InputFileError


def _rows(text: str) -> tuple[list[str], list[dict]]:
    body = "\n".join(ln for ln in text.splitlines() if not ln.startswith("#"))
    reader = csv.DictReader(io.StringIO(body))
    return reader.fieldnames, list(reader)


def _fill(text: str, measured: np.ndarray, u_reading: float | None = 0.3) -> str:
    """The template with the laser readings of each line's own axis filled in."""
    lines = text.splitlines()
    head = [ln for ln in lines if ln.startswith("#")]
    names, rows = _rows(text)
    out = io.StringIO()
    w = csv.DictWriter(out, names, lineterminator="\n")
    w.writeheader()
    for i, row in enumerate(rows):
        c = row["axis"].lower()
        row[f"m{c}_um"] = f"{measured[i, 'xyz'.index(c)]:.4f}"
        row["u_reading_um"] = "" if u_reading is None else f"{u_reading:g}"
        w.writerow(row)
    return "\n".join(head) + "\n" + out.getvalue()


def _predicted(text: str) -> dict:
    _, rows = _rows(text)
    return {q: np.array([[float(r[f"{q}{c}_um"]) for c in "xyz"] for r in rows]) for q in "rUe"}


CASES = {
    "confirmed": lambda r, e: r,
    "sign error": lambda r, e: 2 * e - r,  # e - c with c = r - e: the table negated
    "table not active": lambda r, e: e,
    "size not confirmed": lambda r, e: e + 0.5 * (r - e),  # half the table (a units factor)
}


@pytest.mark.parametrize("case", list(CASES))
def test_simulated_readings_give_the_verdict_of_the_case(exported, tmp_path, case):
    """Readings simulated from the prediction of the case plus the reading noise
    (u = 0.3 µm) and the prediction's own error (U/2): the verdict is the case's, for each
    of 10 seeds."""
    _, _, files = exported
    p = _predicted(files[TEMPLATE])
    u_eps = np.sqrt((p["U"] / 2) ** 2 + 0.3**2)
    for seed in range(10):
        rng = np.random.default_rng(seed)
        m = CASES[case](p["r"], p["e"]) + rng.normal(size=p["r"].shape) * u_eps
        path = tmp_path / f"{seed}.csv"
        path.write_text(_fill(files[TEMPLATE], m))
        result = compare_readings(path)
        assert result.verdict == case, (seed, result.factor, result.chi2, result.chi2_limit)
        doc = result.to_dict()
        assert doc["confirmed"] is (case == "confirmed")
        assert sum(doc["counts"].values()) == len(doc["points"]) == 30


def test_a_sign_error_shows_as_twice_the_error_where_the_table_removes_it(exported, tmp_path):
    """Where the predicted residual is near 0 the flipped table's reading is near 2 e, and
    the estimated multiple of the table is −1."""
    _, _, files = exported
    p = _predicted(files[TEMPLATE])
    path = tmp_path / "flipped.csv"
    path.write_text(_fill(files[TEMPLATE], 2 * p["e"] - p["r"]))
    result = compare_readings(path)
    assert result.factor == pytest.approx(-1.0, abs=1e-3)
    for point in result.points:
        for c in point["components"]:
            if c["discriminates"] and abs(c["r_um"]) < 0.1 * abs(c["e_um"]):
                assert c["measured_um"] == pytest.approx(2 * c["e_um"], rel=0.1)
                assert c["verdict"] == "sign error"


def test_confirmed_in_about_95_percent_of_correct_tables(exported, tmp_path):
    """The false-alarm rate of a correct table whose uncertainties are as stated: κ̂ within
    2 u(κ̂) of 1 (95 %) and χ² under its 99 % point; 200 simulated campaigns."""
    _, _, files = exported
    p = _predicted(files[TEMPLATE])
    u_eps = np.sqrt((p["U"] / 2) ** 2 + 0.3**2)
    rng = np.random.default_rng(2029)
    confirmed = 0
    for _ in range(200):
        m = p["r"] + rng.normal(size=p["r"].shape) * u_eps
        path = tmp_path / "c.csv"
        path.write_text(_fill(files[TEMPLATE], m))
        confirmed += compare_readings(path).confirmed
    assert 0.88 <= confirmed / 200 <= 0.99


def test_no_discriminating_point_is_inconclusive(exported, tmp_path):
    """A reading uncertainty larger than every correction: nothing can be confirmed."""
    _, _, files = exported
    p = _predicted(files[TEMPLATE])
    path = tmp_path / "vague.csv"
    path.write_text(_fill(files[TEMPLATE], p["r"], u_reading=200.0))
    result = compare_readings(path)
    assert result.verdict == "inconclusive" and result.factor is None


def test_bad_files_are_refused_naming_file_line_and_column(exported, tmp_path):
    _, _, files = exported
    p = _predicted(files[TEMPLATE])
    good = _fill(files[TEMPLATE], p["r"])
    lines = good.splitlines()
    header_line = next(i for i, ln in enumerate(lines) if not ln.startswith("#"))
    names = lines[header_line].split(",")
    path = tmp_path / "bad.csv"

    # a non-number at data line 3 (file line header + 3)
    k = header_line + 3
    cells = lines[k].split(",")
    cells[names.index("mx_um")] = "12;5"
    path.write_text("\n".join([*lines[:k], ",".join(cells), *lines[k + 1 :]]) + "\n")
    with pytest.raises(InputFileError) as err:
        compare_readings(path)
    assert str(err.value).startswith(f"{path}, line {k + 1}: column 'mx_um' holds '12;5'")

    # a missing column
    drop = names.index("rx_um")
    path.write_text(
        "\n".join(",".join(c for j, c in enumerate(ln.split(",")) if j != drop) for ln in lines)
    )
    with pytest.raises(InputFileError) as err:
        compare_readings(path)
    assert str(err.value).startswith(f"{path}: missing column 'rx_um'")

    # a reading without its uncertainty, and no --u-reading
    path.write_text(_fill(files[TEMPLATE], p["r"], u_reading=None))
    with pytest.raises(InputFileError) as err:
        compare_readings(path)
    assert str(err.value).startswith(f"{path}, line {header_line + 2}: column 'u_reading_um'")
    assert compare_readings(path, u_reading_um=0.3).verdict == "confirmed"

    # nothing measured
    path.write_text(files[TEMPLATE])
    with pytest.raises(InputFileError, match="no measured deviation"):
        compare_readings(path)
