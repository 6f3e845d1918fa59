"""``analyse`` and ``mtm laser``: the result document says what it is, the console table
states k beside U, and the command line exits 2 with one line on bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.positioning.identify import axis_machine
from mtmetrology.positioning.parameters import evaluate
from mtmetrology.positioning.simulate import iso_targets, simulate_test
from mtmetrology.positioning.workflow import analyse
from mtmetrology.units import from_internal

runner = CliRunner()
MACHINE = "three-axis-xfyz"


@pytest.fixture(scope="module")
def machine():
    return Machine.load(MACHINE)


@pytest.fixture(scope="module")
def truth(machine):
    sub = axis_machine(machine, "X")
    values = np.array([0.010, -0.004, 0.003, 0.002])  # mm: E_XX1..3, E_XXb
    return ParameterSet(sub.parameter_names, values, sub.parameter_units, machine=machine.name)


def test_result_document_kind_machine_category_and_parameters(machine, truth):
    test = simulate_test(machine, truth, "X", iso_targets(800, 1200, 11, seed=1), seed=3)
    res = analyse(test, machine=machine)
    doc = res.to_dict()
    assert (doc["kind"], doc["machine"], doc["category"]) == (
        "iso230-2-positioning", MACHINE, "calibration"
    )  # fmt: skip
    want = evaluate(from_internal(test.deviations, "µm"))
    for key in ("E", "A", "R", "B", "M"):
        assert doc["iso230_2"][key] == pytest.approx(float(want[key]), abs=1e-9)
    unc = doc["uncertainty"]
    assert unc["k"] == 2.0 and unc["U_um"]["E"] == pytest.approx(2 * unc["u_um"]["E"])
    assert json.loads(json.dumps(doc)) == doc
    pitch = doc["pitch_table"]
    np.testing.assert_allclose(pitch["mean_um"], want["mean"], atol=1e-9)
    np.testing.assert_allclose(pitch["reversal_um"], want["B_i"], atol=1e-9)
    # the embedded parameter set reads back as one (mtm export, mtm history add)
    back = ParameterSet.from_document(doc, machine, "r.json")
    assert back.names == ("E_XX1", "E_XX2", "E_XX3", "E_XXb")


def test_without_a_machine_nothing_is_identified(machine, truth):
    test = simulate_test(machine, truth, "X", iso_targets(800, 1200, 6, seed=1), seed=4)
    doc = analyse(test).to_dict()
    assert "category" not in doc and "parameters" not in doc


def mtm(*args):
    return runner.invoke(app, [str(a) for a in args])


def test_cli_simulate_then_analyse(tmp_path):
    csv = tmp_path / "t.csv"
    assert mtm("laser", "simulate", "--machine", MACHINE, "-o", csv, "--seed", 2).exit_code == 0
    res = mtm("laser", "analyse", csv, "--machine", MACHINE, "--json")
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["kind"] == "iso230-2-positioning" and doc["edition"] == "2014"
    res = mtm("laser", "analyse", csv, "--machine", MACHINE, "--degrees", "1,2", "--json")
    assert [p["name"] for p in json.loads(res.stdout)["parameters"]] == ["E_XX1", "E_XX2", "E_XXb"]
    assert mtm("laser", "analyse", csv, "--machine", MACHINE, "--degrees", "x").exit_code == 2
    res = mtm("laser", "analyse", csv, "--edition", "vdi3441")
    assert res.exit_code == 0 and "(k = 2)" in res.stdout.splitlines()[1]


def test_cli_bad_input_exits_2_with_one_line(tmp_path):
    csv = tmp_path / "t.csv"
    csv.write_text("target,position_mm,run,direction,deviation_um\n1,0,1,+,0.1\n")
    res = mtm("laser", "analyse", csv)
    assert res.exit_code == 2
    assert len(res.stderr.strip().splitlines()) == 1
    res = mtm("laser", "analyse", csv, "--edition", "1066")
    assert res.exit_code == 2


def test_cli_budget_file_changes_u_and_a_bad_one_is_refused(tmp_path):
    csv = tmp_path / "t.csv"
    assert mtm("laser", "simulate", "--machine", MACHINE, "-o", csv, "--seed", 5).exit_code == 0
    base = json.loads(mtm("laser", "analyse", csv, "--json").stdout)
    (tmp_path / "b.yaml").write_text("misalignment_rad: 0.002\n")
    wide = json.loads(
        mtm("laser", "analyse", csv, "--json", "--budget", tmp_path / "b.yaml").stdout
    )
    assert wide["uncertainty"]["u_um"]["E"] > base["uncertainty"]["u_um"]["E"]
    (tmp_path / "c.yaml").write_text("misalignment_rad: wide\n")
    res = mtm("laser", "analyse", csv, "--budget", tmp_path / "c.yaml")
    assert res.exit_code == 2 and "misalignment_rad" in res.stderr


def test_cli_report_holds_the_deviation_figure(tmp_path):
    csv, html = tmp_path / "t.csv", tmp_path / "r.html"
    assert mtm("laser", "simulate", "--machine", MACHINE, "-o", csv, "--seed", 6).exit_code == 0
    res = mtm("laser", "analyse", csv, "--report", html)
    assert res.exit_code == 0, res.output
    assert html.read_text().count("<svg") >= 1


def test_deviation_figure_draws_both_directions_with_bands(machine, truth):
    from mtmetrology.positioning.report import deviation_figure

    test = simulate_test(machine, truth, "X", iso_targets(800, 1200, 6, seed=1), seed=7)
    ax = deviation_figure(analyse(test)).axes[0]
    up = ax.lines[0].get_ydata()
    np.testing.assert_allclose(up, from_internal(test.deviations[:, :, 0].mean(axis=1), "µm"))
    assert len(ax.collections) == 2 and ax.get_ylabel() == "positional deviation (µm)"


def test_the_result_shows_itself_in_a_notebook(machine, truth):
    test = simulate_test(machine, truth, "X", iso_targets(800, 1200, 6, seed=1), seed=8)
    html = analyse(test)._repr_html_()
    assert "<svg" in html and "ISO/TR 230-9 budget" in html
