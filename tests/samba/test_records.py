"""SAMBA records: raw points reduced by the known-radius sphere fit, campaigns, and the
bad inputs that must be refused with the file and line named."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.io.files import InputFileError
from mtmetrology.samba import calibrate, read_records, simulate_records

from .samba_helpers import NOISE


def test_raw_points_reduce_to_the_centre_indications(simulated, machine13, truth13, artefact):
    """Noise-free: the known-radius sphere of 5 points (equator + pole) gives the centre
    readings in X and Y to the 1 nm of the file.  In Z only the pole is probed, so the
    fit moves the centre by ρ·E_ZZ1 (the machine reads the pole offset ρ with its own Z
    scale): a constant shift of every indication, as on the real machine, which the tool
    length absorbs — the identified errors are those of the centre indications."""
    centres = simulated()
    raw = simulated(
        name="raw.csv",
        raw_points=True,
    )
    assert raw.form == "raw-points" and centres.form == "centres"
    assert raw.balls == centres.balls
    np.testing.assert_allclose(raw.readings[:, :2], centres.readings[:, :2], atol=2e-6)
    shift = raw.readings[:, 2] - centres.readings[:, 2]
    rho = 0.5 * (19.05 + artefact.stylus_tip_diameter_mm)
    zz1 = truth13[machine13.parameter_names.index("E_ZZ1")]
    np.testing.assert_allclose(shift, -rho * zz1, atol=3e-6)
    # the scale gains (≈1e-4) shrink the probed sphere by ρ·E_XX1 ... in reading space
    assert np.all(raw.sphere_rms < rho * zz1)
    a = calibrate(machine13, raw, artefact, sigma=NOISE, estimate_tool=True).parameters
    b = calibrate(machine13, centres, artefact, sigma=NOISE, estimate_tool=True).parameters
    assert np.all(np.abs(a.values - b.values) < 0.02 * b.standard_uncertainty)


def test_raw_points_and_centres_give_the_same_parameters_within_their_uncertainties(
    simulated, machine13, artefact, noisy_calibration
):
    """The same simulated test as raw points (0.5 µm per point, 7 points per probing):
    |θ_raw − θ_centres| < 3 sqrt(u_raw² + u_centres²) for every parameter."""
    raw = simulated(
        name="raw.csv",
        raw_points=True,
        points_per_ball=7,
        noise=NOISE,
        seed=12,
    )
    cal = calibrate(machine13, raw, artefact, sigma=NOISE, estimate_tool=True)
    a, b = cal.parameters, noisy_calibration.parameters
    combined = np.hypot(a.standard_uncertainty, b.standard_uncertainty)
    assert np.all(np.abs(a.values - b.values) < 3 * combined)


def test_campaigns_are_averaged_and_kept(simulated, programme):
    rec = simulated(
        noise=NOISE,
        campaigns=3,
        seed=2,
    )
    assert rec.n_campaigns == 3 and len(rec) == len(programme)
    linear = [0, 1, 2]
    np.testing.assert_allclose(rec.readings[:, linear], rec.campaigns.mean(axis=0))


def _write(path, header, rows):
    path.write_text("\n".join([header, *rows]) + "\n", encoding="utf-8")
    return path


@pytest.fixture
def good_rows(machine13, truth13, balls, programme, artefact):
    rec = simulate_records(machine13, truth13, balls, programme, artefact)
    return ",".join(rec.header), [",".join(r) for r in rec.rows]


def _set(rows, header, row, column, value):
    cells = rows[row].split(",")
    cells[header.split(",").index(column)] = value
    return [*rows[:row], ",".join(cells), *rows[row + 1 :]]


@pytest.mark.parametrize(
    ("edit", "line", "field"),
    [
        (lambda rows, h: _set(rows, h, 0, "X", "nan"), 2, "column 'X'"),
        (lambda rows, h: _set(rows, h, 0, "B", "120"), 2, "B = 120"),
        (lambda rows, h: _set(rows, h, 0, "ball", "9"), 2, "ball '9'"),
        (lambda rows, h: [r for r in rows if not r.startswith("4,")] + [rows[3]], None, "'4'"),
        (lambda rows, h: [r for r in rows if not r.startswith("SB")], None, "SB1, SB2"),
    ],
    ids=["nan", "outside-travel", "unknown-ball", "ball-probed-once", "bar-never-probed"],
)
def test_bad_records_name_the_file_line_and_field(
    tmp_path, machine13, artefact, good_rows, edit, line, field
):
    header, rows = good_rows
    path = _write(tmp_path / "bad.csv", header, edit(rows, header))
    with pytest.raises(InputFileError) as err:
        read_records(path, machine13, artefact)
    text = str(err.value)
    assert text.startswith(str(path)) and "\n" not in text
    if line is not None:
        assert f"line {line}:" in text
    assert field in text


def test_campaigns_must_repeat_the_same_test(tmp_path, machine13, artefact, good_rows):
    header, rows = good_rows
    second = [
        r.replace(",0.000000,0.000000,0.000000", ",0.000000,10.000000,0.000000", 1) for r in rows
    ]
    path = _write(
        tmp_path / "c.csv",
        "campaign," + header,
        [f"1,{r}" for r in rows] + [f"2,{r}" for r in second],
    )
    with pytest.raises(InputFileError, match="campaign '2' does not repeat"):
        read_records(path, machine13, artefact)


def test_raw_measurement_needs_four_points_and_the_tip_diameter(tmp_path, machine13, artefact):
    rows = [f"1,1,{x},0,0,0,0,0" for x in (1.0, 2.0, 3.0)]
    path = _write(tmp_path / "raw.csv", "measurement,ball,X,Y,Z,B,C,S", rows)
    with pytest.raises(InputFileError, match="has 3 points"):
        read_records(path, machine13, artefact)
    no_tip = artefact.model_copy(update={"stylus_tip_diameter_mm": None})
    with pytest.raises(InputFileError, match="stylus_tip_diameter_mm"):
        read_records(path, machine13, no_tip)
