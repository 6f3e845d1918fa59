"""The measured pitch table exported point by point (export.tabulated): from the laser run
to the control, the control's emulation (not the writer) applies the files, and the residual
is within the exact interpolation bound of the measured table; against the truth of the
virtual axis it is within that bound plus the stated U (k = 2)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.errors import InputError
from mtmetrology.export.control import residual
from mtmetrology.export.emulation import emulate
from mtmetrology.export.tabulated import MeasuredTable, interpolation_bound, tabulated_model
from mtmetrology.export.workflow import export_compensation
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.positioning.identify import axis_machine, readings_along
from mtmetrology.positioning.simulate import iso_targets, simulate_test
from mtmetrology.positioning.workflow import analyse
from mtmetrology.units import to_internal

MACHINE = "three-axis-xfyz"
PITCH = 25.0  # mm
#: the files hold mm to 6 decimals: 0.5 nm of rounding per value
ROUNDING_UM = 0.002


@pytest.fixture(scope="module")
def machine():
    return Machine.load(MACHINE)


@pytest.fixture(scope="module")
def run(machine):
    """A virtual X axis with a cubic E_XX and a reversal, measured per ISO 230-2 (no
    machine given to the analysis: the pitch table needs no identification)."""
    sub = axis_machine(machine, "X")
    truth = ParameterSet(
        sub.parameter_names, np.array([0.012, -0.006, 0.004, 0.003]), sub.parameter_units,
        machine=machine.name,
    )  # fmt: skip
    targets = iso_targets(800, 1200, 21, seed=5)
    test = simulate_test(machine, truth, "X", targets, sigma_mm=0.0008, seed=9)
    return truth, json.loads(json.dumps(analyse(test).to_dict()))


def _true_residual(machine, truth, control, q, senses):
    """What the emulated control leaves of the TRUE error (the kinematic chain with the
    truth's parameters), mm (n, 3)."""
    m = truth.machine_for(machine)
    return residual(m, truth.vector_for(m), None, control.tables, q, senses)[0]


@pytest.mark.parametrize(
    ("fmt", "bidirectional"), [("linuxcnc", True), ("siemens", False), ("siemens", True)]
)
def test_from_laser_run_to_control_with_the_measured_table(machine, run, fmt, bidirectional):
    truth, doc = run
    measured = MeasuredTable.from_result(doc, "laser.json", bidirectional=bidirectional)
    t = measured.positions
    q = np.repeat(readings_along(machine, "X", t), 2, axis=0)
    senses = np.zeros_like(q)
    senses[:, 0] = np.tile([1.0, -1.0], t.size)
    out = export_compensation(machine, measured, fmt, pitch=PITCH, at=q, at_senses=senses)
    check = out.to_dict()["residual"]
    bound = check["interpolation_bound_um"]
    # the check grid's residual (both senses) is within the measured table's exact bound
    assert check["max_um"] <= bound + ROUNDING_UM
    assert check["negative"]["max_um"] <= bound + ROUNDING_UM
    if bidirectional:  # per-direction tables leave interpolation only
        assert bound < 0.1 * check["negative"]["uncompensated_max_um"]
    else:  # the mean leaves half the reversal in each direction
        half = 0.5 * np.abs(np.subtract(doc["pitch_table"]["reversal_um"], 0)).max()
        assert bound >= half - ROUNDING_UM
    # against the truth at the targets: the reported residual r̂ there is within U (k = 2)
    # at about the coverage probability (42 values; a sign or direction error fails all)
    control = emulate(fmt, out.files, machine)
    r_true = _true_residual(machine, truth, control, q, senses)[:, 0] * 1e3  # µm
    at = out.at_points
    covered = np.abs(r_true - at["r"][:, 0]) <= at["U"][:, 0]
    assert covered.mean() >= 0.9


def test_per_direction_files_hold_each_directions_mean(machine, run):
    """LinuxCNC type 1: forward column −x̄↑, reverse column −x̄↓ at the targets on the
    grid (the table read back through the emulation)."""
    _, doc = run
    measured = MeasuredTable.from_result(doc, "laser.json")
    out = export_compensation(machine, measured, "linuxcnc", pitch=PITCH)
    (table,) = emulate("linuxcnc", out.files, machine).tables
    on_grid = np.isin(table.positions, measured.positions)
    fwd = np.interp(table.positions, measured.positions, measured.forward)
    rev = np.interp(table.positions, measured.positions, measured.reverse)
    np.testing.assert_allclose(table.forward, -fwd, atol=1e-6)
    np.testing.assert_allclose(table.reverse, -rev, atol=1e-6)
    assert np.any(on_grid)  # the first target (800 mm) is a grid point
    assert not np.allclose(table.forward, table.reverse)


def test_interpolation_bound_is_exact_for_one_kink(machine):
    """Targets 800, 810, 1200 mm with E = 0, 10, 0 µm; at pitch 25 the grid holds
    E(825) = 10·375/390 µm, the control interpolates 0.4·E(825) at 810: the residual there
    is 10 − 0.4·10·375/390 µm, the largest over the axis."""
    e = to_internal(np.array([0.0, 10.0, 0.0]), "µm")
    u = np.full(3, 1e-4)
    measured = MeasuredTable("X", np.array([800.0, 810.0, 1200.0]), e, e, u, u)
    want = 10.0 - 0.4 * 10.0 * 375 / 390
    model = tabulated_model(machine, measured, pitch=PITCH)
    assert interpolation_bound(model) * 1e3 == pytest.approx(want, abs=1e-9)
    q = readings_along(machine, "X", np.array([810.0]))
    out = export_compensation(machine, measured, "linuxcnc", pitch=PITCH, at=q)
    assert out.at_points["r"][0, 0] == pytest.approx(want, abs=ROUNDING_UM)
    assert out.residual["interpolation_bound_um"] == pytest.approx(want, abs=1e-9)


def test_targets_on_the_grid_leave_no_residual(machine):
    t = 800.0 + PITCH * np.arange(17)
    e = to_internal(5.0 * np.sin(t / 30.0), "µm")
    u = np.full(t.size, 1e-4)
    out = export_compensation(machine, MeasuredTable("X", t, e, e, u, u), "siemens", pitch=PITCH)
    assert out.residual["interpolation_bound_um"] == pytest.approx(0.0, abs=1e-9)
    assert out.residual["max_um"] <= ROUNDING_UM
    assert out.residual["uncompensated_max_um"] > 4.0


def test_bad_input_refused(machine, run):
    _, doc = run
    with pytest.raises(InputError, match="kind"):
        MeasuredTable.from_result({"kind": "parameter-set"}, "p.json")
    with pytest.raises(InputError, match="machine"):
        MeasuredTable.from_result(doc | {"machine": "other"}, "l.json", machine=MACHINE)
    bad = json.loads(json.dumps(doc))
    bad["pitch_table"]["position_mm"][3] = bad["pitch_table"]["position_mm"][2]
    with pytest.raises(InputError, match="ascending"):
        MeasuredTable.from_result(bad, "l.json")
    measured = MeasuredTable.from_result(doc, "l.json")
    with pytest.raises(InputError, match="axes"):
        export_compensation(machine, measured, "linuxcnc", pitch=PITCH, axes=["Y"])
    with pytest.raises(InputError, match="--bound"):
        export_compensation(machine, measured, "linuxcnc", pitch=PITCH, bound_um=1.0)
    with pytest.raises(InputError, match="grid"):
        export_compensation(machine, measured, "grid", pitch=PITCH)


def test_mtm_export_measured(run, tmp_path):
    _, doc = run
    path = tmp_path / "laser.json"
    path.write_text(json.dumps(doc))
    runner = CliRunner()
    argv = ["export", "linuxcnc", str(path), "--machine", MACHINE, "--pitch", "25"]
    out = ["-o", str(tmp_path / "a"), "--json"]
    res = runner.invoke(app, [*argv, "--measured", "bidirectional", *out])
    assert res.exit_code == 0, res.output
    check = json.loads(res.stdout)
    assert check["provenance"]["pitch_table"]["tabulated"] == "per direction"
    assert check["residual"]["max_um"] <= check["residual"]["interpolation_bound_um"] + ROUNDING_UM
    assert "correction_reverse" in check["tables"][0]
    res = runner.invoke(app, [*argv, "--measured", "both", "-o", str(tmp_path / "b")])
    assert res.exit_code == 2
    assert not (tmp_path / "b").exists()
