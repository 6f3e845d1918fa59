"""A SAMBA plan with two styli (Alami Mchichi (2018) Table 4.4): one stylus confounds E_AY1
with E_YY1, a second stylus length resolves them; what the second stylus buys is reported."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.design.accessibility import AccessibilityRule
from mtmetrology.design.inputs import ScaleBarPlacement, grid_indexations
from mtmetrology.design.programme import nominal_jacobian, programme_problem
from mtmetrology.design.samba import plan_samba
from mtmetrology.errors import InputError, RankDeficientError
from mtmetrology.kinematics import Machine

PAIRS = grid_indexations(np.arange(-90, 91, 30), np.arange(0, 360, 45))
BALLS = (["1", "2"], [[-50.0, -50.0, 50.0], [50.0, 50.0, 60.0]])
STYLI = [("long", (0.0, 0.0, -150.0)), ("short", (0.0, 0.0, -200.0))]
FREE = AccessibilityRule(check_travel=False)


@pytest.fixture(scope="module")
def m14():
    m = Machine.load("five-axis-wcbxfzyst", "13")
    return m.with_parameters([*m.parameter_names, "E_AY1"])


@pytest.fixture(scope="module")
def design(m14):
    return plan_samba(m14, PAIRS, balls=BALLS, k=3, starts=1, seed=0, tools=STYLI, rule=FREE)


def test_one_stylus_plan_is_refused_two_resolve_the_pair(m14, design):
    with pytest.raises(RankDeficientError, match="second stylus") as err:
        plan_samba(m14, PAIRS, balls=BALLS, k=3, starts=1, seed=0, rule=FREE)
    assert [set(g) for g in err.value.confounded] == [{"E_AY1", "E_YY1"}]
    gain = design.to_dict()["stylus_gain"]
    one, every = gain["one_stylus"], gain["all_styli"]
    assert [set(g) for g in one["confounded"]] == [{"E_AY1", "E_YY1"}]
    assert one["rank"] == one["n_unknowns"] - 1 and one["condition_scaled"] is None
    assert every["confounded"] == [] and every["rank"] == every["n_unknowns"]
    assert every["n_unknowns"] == one["n_unknowns"] + 3  # the second stylus's vector
    assert gain["resolved"] == ["E_AY1", "E_YY1"]
    assert all(q["u_one"] is None and q["u_all"] > 0 for q in gain["parameters"])


def test_the_one_stylus_null_direction_is_the_closed_form_lever_arm(m14, design):
    """A roll ε of the Y carriage growing with y moves a stylus of vector (0, 0, t_z) by
    δy = −ε t_z y (ε × t), the Y gain e by δy = e y: the null vector of the one-stylus
    Jacobian has Δe/Δε = t_z exactly (internal units, rad/mm for E_AY1), and nothing else."""
    one = design.one_stylus
    bar = ScaleBarPlacement()
    centres = dict(zip(BALLS[0], np.array(BALLS[1]), strict=True))
    centres |= dict(zip(bar.ends, bar.centres_mm, strict=True))
    tool = np.array([STYLI[0][1]])
    prob = programme_problem(m14, one.rows, centres, bar, one.sigma_mm, tool)
    v = np.linalg.svd(nominal_jacobian(prob))[2][-1]
    i, j = prob.names.index("E_YY1"), prob.names.index("E_AY1")
    assert v[i] / v[j] == pytest.approx(tool[0, 2], rel=1e-9)
    assert np.abs(np.delete(v, [i, j])).max() < 1e-9 * abs(v[j])


def test_a_second_stylus_never_raises_a_parameter_u():
    """13 parameters, full rank with one stylus: the two-stylus programme holds the
    one-stylus rows plus rows whose only new unknowns are the second tool vector, so the
    information on every machine parameter can only grow (Schur complement ⪰ 0)."""
    m = Machine.load("five-axis-wcbxfzyst", "13")
    d = plan_samba(m, PAIRS, balls=BALLS, k=3, starts=1, seed=1, tools=STYLI, rule=FREE)
    n = d.one_stylus.n_measurements
    assert d.programme.n_measurements == 2 * n  # the same rows with each stylus
    assert d.programme.rows.balls[:n] == d.one_stylus.rows.balls
    gain = d.stylus_gain()
    assert gain["resolved"] == [] and gain["one_stylus"]["confounded"] == []
    for q in gain["parameters"]:
        assert q["u_all"] <= q["u_one"] * (1 + 1e-9), q["name"]


def test_several_styli_means_two_of_them(m14):
    """(Step 1 with several styli: tests/design/test_design_step1_styli.py.)"""
    with pytest.raises(InputError, match="two or more styli"):
        plan_samba(m14, PAIRS, balls=BALLS, tools=STYLI[:1])


def test_cli_writes_the_tool_column_and_the_artefact_tools(tmp_path):
    balls = tmp_path / "balls.yaml"
    balls.write_text(
        "kind: samba-balls\nballs:\n  - {id: '1', centre_mm: [-50, -50, 50]}\n"
        "  - {id: '2', centre_mm: [50, 50, 60]}\n"
    )
    names = "E_A0B,E_C0B,E_X0C,E_A0C,E_B0C,E_B0Z,E_A0Y,E_C0Y,E_XX1,E_YY1,E_ZZ1,E_Y0S,E_X0S,E_AY1"
    out, art = tmp_path / "plan.csv", tmp_path / "artefact.yaml"
    args = ["samba", "plan", "--machine", "five-axis-wcbxfzyst", "--params-only", names]
    args += ["--balls", str(balls), "--b-grid", "-90:90:30", "--c-grid", "0:315:45"]
    args += ["--tool", "long=0,0,-150", "--tool", "short=0,0,-200", "--starts", "1"]
    args += ["--seed", "0", "-o", str(out), "--artefact-out", str(art), "--json"]
    args += ["--report", str(tmp_path / "plan.html")]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["stylus_gain"]["resolved"] == ["E_AY1", "E_YY1"]
    assert [t["id"] for t in doc["tools"]] == ["long", "short"]
    lines = out.read_text().splitlines()
    assert lines[0].split(",")[-1] == "tool"
    assert {r.split(",")[-1] for r in lines[1:]} == {"long", "short"}
    assert "tools:" in art.read_text().splitlines()
    assert "What the second stylus buys" in (tmp_path / "plan.html").read_text()


def test_planned_u_is_the_calibrations_for_the_two_stylus_programme(tmp_path):
    """design → identifiability, simulate → calibrate with two styli: the programme's tool
    column and the artefact's tools carry through (``mtm machine identifiability`` gives
    the plan's rank and condition), and the calibration's u of every parameter (σ = 1 µm,
    the bar's u = 1 µm, as planned) is the plan's predicted u to 1 % (the calibration's
    Jacobian is taken at the estimate, the plan's at the nominal)."""
    balls = tmp_path / "balls.yaml"
    balls.write_text(
        "kind: samba-balls\nballs:\n  - {id: '1', centre_mm: [-50, -50, 50]}\n"
        "  - {id: '2', centre_mm: [50, 50, 60]}\n"
    )
    names = "E_A0B,E_C0B,E_X0C,E_A0C,E_B0C,E_B0Z,E_A0Y,E_C0Y,E_XX1,E_YY1,E_ZZ1,E_Y0S,E_X0S,E_AY1"
    machine = ["--machine", "five-axis-wcbxfzyst", "--params-only", names]
    plan, art, placed = tmp_path / "plan.csv", tmp_path / "art.yaml", tmp_path / "b.yaml"
    runner = CliRunner()
    args = ["samba", "plan", *machine, "--balls", str(balls), "--b-grid", "-90:90:30"]
    args += ["--c-grid", "0:315:45", "--tool", "long=0,0,-150", "--tool", "short=0,0,-200"]
    args += ["--starts", "1", "--seed", "0", "-o", str(plan), "--artefact-out", str(art)]
    args += ["--balls-out", str(placed), "--json"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    plan_doc = json.loads(result.stdout)
    planned = {p["name"]: p["u"] for p in plan_doc["parameters"]}
    # mtm machine identifiability reads the tool column: the plan's own diagnostics
    args = ["machine", "identifiability", "five-axis-wcbxfzyst", str(plan), "--model", "13"]
    args += ["--add", "E_AY1", "--artefact", str(art), "--json"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    ident = json.loads(result.stdout)
    assert ident["n_unknowns"] == plan_doc["n_unknowns"] == ident["rank"]
    assert ident["condition_scaled"] == pytest.approx(plan_doc["condition_scaled"], rel=1e-6)
    records = tmp_path / "rec.csv"
    args = ["samba", "simulate", "--machine", "five-axis-wcbxfzyst", "--artefact", str(art)]
    args += ["--balls", str(placed), "--poses", str(plan), "--noise-um", "0", "-o", str(records)]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    args = ["samba", "calibrate", str(records), *machine, "--artefact", str(art)]
    args += ["--estimate-tool", "--noise-um", "1", "--json"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert [t["id"] for t in doc["tools"]] == ["long", "short"]
    for p in doc["propagation_factors"]:
        assert p["u"] == pytest.approx(planned[p["name"]], rel=0.01), p["name"]
