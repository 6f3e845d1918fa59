"""Tests for ``mtm task uncertainty`` (mtmetrology.cli.task)."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.io import write_json
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.omm.repeatability import (
    COVARIANCE_OUTPUTS,
    STD_OUTPUTS,
    factors_from_file_units,
)
from mtmetrology.omm.repeatability_model import OutputFit, RepeatabilityModel
from mtmetrology.units import to_internal

runner = CliRunner()
MACHINE = Machine.load("five-axis-wcbxfzyst")
UM = to_internal(1.0, "µm")
# Table 7-1 gauge-block readings, approaching the two faces along +X and −X.
POINTS = """point,X,Y,Z,B,C,i,j,k,end
p1,-138.5650,94.6560,196.2320,-42,-293,1,0,0,1
p2,-61.2880,48.3440,246.8170,-64,-124,-1,0,0,2
"""
E_COV = [[45.0, -17.0, 5.0], [-17.0, 66.0, 7.0], [5.0, 7.0, 58.0]]  # µm²
E_PRINTED = [[45.0, -17.0, -220.0], [-17.0, 66.0, 7.0], [-220.0, 7.0, 58.0]]  # eq. 6-15


def _files(tmp_path, *, e_cov=E_COV, machine=MACHINE.name, z_high=260.0, cov_scale=1.0):
    (tmp_path / "points.csv").write_text(POINTS, encoding="utf-8")
    rng = np.random.default_rng(1)
    a = MACHINE.parameter_scales[:, None] * rng.normal(size=(13, 13))  # row i in its unit
    ParameterSet(
        MACHINE.parameter_names,
        rng.normal(size=13) * MACHINE.parameter_scales * 3,
        MACHINE.parameter_units,
        covariance=cov_scale * a @ a.T,
        machine=machine,
    ).save(tmp_path / "params.json")
    write_json(
        tmp_path / "E.json",
        {"kind": "unexplained-volumetric-error", "version": 1, "unit": "µm²", "covariance": e_cov},
    )
    fits = []
    for name in STD_OUTPUTS + COVARIANCE_OUTPUTS:
        size = 22 if name in STD_OUTPUTS else 36
        c = np.zeros(size)
        c[0] = UM if name in STD_OUTPUTS else 0.0  # σ = 1 µm, no covariance
        fits.append(OutputFit(name, c, np.zeros(size), 1.0, None, None))
    model = RepeatabilityModel(
        factors_from_file_units(0, 0, -90, -360, -220, -170, -110)[0],
        factors_from_file_units(90, 360, 90, 360, 230, 180, z_high)[0],
        tuple(fits),
        50,
        0,
    )
    write_json(tmp_path / "R.json", model.to_dict())
    return tmp_path


def _statement(extra) -> list[str]:
    """--recalibrated unless the call states the long-term variation itself."""
    return [] if {"--long-term", "--recalibrated"} & set(extra) else ["--recalibrated"]


def _run(tmp_path, *extra):
    base = [
        "task",
        "uncertainty",
        str(tmp_path / "points.csv"),
        "--machine",
        MACHINE.name,
        "--params",
        str(tmp_path / "params.json"),
        "--feature",
        "length",
    ]
    return runner.invoke(app, [*base, *_statement(extra), *extra])


def test_length_with_unexplained_errors_only_matches_the_closed_form(tmp_path):
    d = _files(tmp_path, cov_scale=0.0)  # parameters known exactly
    result = _run(d, "--unexplained", str(d / "E.json"), "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    (out,) = doc["outputs"]
    q = np.array(doc["points"]["compensated"])
    e = (q[1] - q[0]) / np.linalg.norm(q[1] - q[0])
    u = np.sqrt(2 * e @ (np.array(E_COV) * UM**2) @ e)
    assert out["u"] == pytest.approx(u, rel=1e-9)
    assert out["value"] == pytest.approx(np.linalg.norm(q[1] - q[0]) - 2 * MACHINE.tip_radius)
    assert doc["budget_groups"]["gauge_length"]["unexplained_volumetric_error"] == pytest.approx(
        1.0
    )


def test_without_repeatability_or_e_u_is_the_calibration_contribution(tmp_path):
    """u² = c G U_θ Gᵀ cᵀ (c: the length's gradient, G = ∂f/∂δ at the compensated points);
    with --long-term the same covariance once more: u² doubles."""
    d = _files(tmp_path)
    result = _run(d, "--recalibrated", "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    pset = ParameterSet.load(d / "params.json", MACHINE)
    q = MACHINE.readings_from_customary(
        {"X": [-138.565, -61.288], "Y": [94.656, 48.344], "Z": [196.232, 246.817],
         "B": [-42.0, -64.0], "C": [-293.0, -124.0]}
    )  # fmt: skip
    g = MACHINE.jacobian(q, pset.values).reshape(6, 13)
    p = np.array(doc["points"]["compensated"])
    e = (p[1] - p[0]) / np.linalg.norm(p[1] - p[0])
    c = np.concatenate([-e, e]) @ g
    u = doc["outputs"][0]["u"]
    assert u == pytest.approx(np.sqrt(c @ pset.covariance @ c), rel=1e-9)
    assert doc["budget_groups"]["gauge_length"]["calibration"] == pytest.approx(1.0)
    assert doc["measurement_model"]["long_term_variation"] == "recalibrated"
    both = json.loads(_run(d, "--long-term", str(d / "params.json"), "--json").stdout)
    assert both["outputs"][0]["u"] == pytest.approx(np.sqrt(2) * u, rel=1e-9)
    assert both["budget_groups"]["gauge_length"]["long_term_variation"] == pytest.approx(0.5)


def test_full_task_with_repeatability_tolerance_and_output_file(tmp_path):
    d = _files(tmp_path)
    out_path = d / "out.json"
    first = json.loads(_run(d, "--unexplained", str(d / "E.json"), "--json").stdout)
    value = first["outputs"][0]["value"]
    result = _run(
        d,
        "--unexplained",
        str(d / "E.json"),
        "--repeatability",
        str(d / "R.json"),
        "--tolerance",
        f"{value},-0.1,0.1",
        "-o",
        str(out_path),
    )
    assert result.exit_code == 0, result.output
    doc = json.loads(out_path.read_text(encoding="utf-8"))
    groups = doc["budget_groups"]["gauge_length"]
    # 1 µm isotropic repeatability per point adds 2 µm² along the gauge axis.
    assert groups["repeatability"] > 0 and groups["calibration"] > 0
    assert sum(groups.values()) == pytest.approx(1.0, abs=1e-12)
    u_e = first["outputs"][0]["u"]
    assert doc["outputs"][0]["u"] == pytest.approx(np.sqrt(u_e**2 + 2 * UM**2), rel=1e-6)
    assert doc["decision"]["decision"] == "conformance"


@pytest.mark.parametrize(
    ("files", "extra", "named"),
    [
        # eq. 6-15 as printed: not PSD; the file, its field and the smallest eigenvalue
        (
            {"e_cov": E_PRINTED},
            ["--unexplained", "E.json"],
            lambda d: (
                f"{d / 'E.json'}: covariance is not positive semidefinite",
                f"smallest eigenvalue {np.linalg.eigvalsh(E_PRINTED)[0]:.3g} µm²",
            ),
        ),
        # parameter file of another machine: the file and both machine names
        (
            {"machine": "another-machine"},
            ["--unexplained", "E.json"],
            lambda d: (
                f"{d / 'params.json'}: made for machine 'another-machine'",
                f"not '{MACHINE.name}'",
            ),
        ),
        # p2 at Z = 246.817 mm is outside the model's Z range [-110, 200] mm
        (
            {"z_high": 200.0},
            ["--repeatability", "R.json"],
            lambda d: ("pose factor Z_T = 246.817 mm", "range [-110, 200] mm"),
        ),
        (
            {},
            ["--tolerance", "500,0.1,-0.1"],
            lambda d: ("tolerance: the lower limit 500.1 is above the upper limit 499.9",),
        ),
        (
            {},
            ["--unexplained", "E.json", "--tip-diameter", "-1"],
            lambda d: ("tip_diameter must be a finite length >= 0 mm, got -1.0",),
        ),
        # a machine recalibrated for the task has no long-term term: contradictory
        (
            {},
            ["--recalibrated", "--long-term", "params.json"],
            lambda d: ("--long-term and --recalibrated: a machine recalibrated",),
        ),
    ],
    ids=["e-not-psd", "another-machine", "outside-model", "tolerance", "tip", "contradictory"],
)
def test_bad_input_exits_2_naming_the_file_field_or_option(tmp_path, files, extra, named):
    d = _files(tmp_path, **files)
    extra = [str(d / x) if x.endswith(".json") else x for x in extra]
    out = d / "out.json"
    result = _run(d, *extra, "-o", str(out))
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ")
    first, *rest = named(d)
    assert lines[0].startswith(f"error: {first}"), lines[0]
    assert all(part in lines[0] for part in rest), lines[0]
    assert not out.exists()


def test_the_long_term_variation_must_be_stated(tmp_path):
    """Neither --long-term nor --recalibrated: refused, one line, nothing written."""
    d = _files(tmp_path)
    out = d / "out.json"
    result = runner.invoke(
        app,
        [
            "task", "uncertainty", str(d / "points.csv"), "--machine", MACHINE.name,
            "--params", str(d / "params.json"), "--feature", "length", "-o", str(out),
        ],
    )  # fmt: skip
    assert result.exit_code == 2
    (line,) = result.stderr.strip().splitlines()
    assert line == (
        "error: state the long-term variation of the parameters since the calibration: "
        "--long-term FILE (mtm samba long-term), or --recalibrated"
    )
    assert not out.exists()


def test_three_points_for_a_length_are_refused(tmp_path):
    d = _files(tmp_path)
    (d / "points.csv").write_text(POINTS + "p3,0,0,0,0,0,1,0,0,2\n", encoding="utf-8")
    result = _run(d, "--unexplained", str(d / "E.json"))
    assert result.exit_code == 2
    line = f"error: {d / 'points.csv'}: a length needs exactly 2 points (one pair), got 3\n"
    assert result.stderr == line


def test_report_shows_the_result_budget_and_decision(tmp_path):
    """--report: value and U as in the JSON, one budget figure, one conformity figure."""
    d = _files(tmp_path)
    first = json.loads(_run(d, "--unexplained", str(d / "E.json"), "--json").stdout)
    value = first["outputs"][0]["value"]
    report = d / "task.html"
    result = _run(
        d, "--unexplained", str(d / "E.json"), "--tolerance", f"{value},-0.1,0.1",
        "--json", "--report", str(report),
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    html = report.read_text(encoding="utf-8")
    assert html.count("<svg") == 2  # budget bars and conformity zones
    assert f"{doc['outputs'][0]['value']:.6f}" in html
    assert doc["decision"]["decision"] == "conformance"
    assert f"Conformity decision of {doc['outputs'][0]['name']} (ISO 14253-1:2017)" in html


def _bore_points(d, n=8, radius=20.0, plane=False):
    """A Ø 40 mm bore (or a 40 mm square of plane points) at Z = 100 mm, B = C = 0."""
    t = np.linspace(0, 2 * np.pi, n, endpoint=False) + 0.1
    if plane:
        pts = np.column_stack([radius * np.cos(t), radius * np.sin(t), np.full(n, 100.0)])
        normal = np.tile([0.0, 0.0, -1.0], (n, 1))  # the probe moves down onto the face
    else:
        pts = np.column_stack([radius * np.cos(t), radius * np.sin(t), np.full(n, 100.0)])
        normal = pts * [1, 1, 0] / radius  # towards the wall of the bore
    q = MACHINE.inverse(pts, np.zeros((n, 6)))
    rows = ["point,X,Y,Z,B,C,i,j,k"] + [
        f"p{s + 1},{q[s, 0]:.6f},{q[s, 1]:.6f},{q[s, 2]:.6f},0,0,{normal[s, 0]:.6f},"
        f"{normal[s, 1]:.6f},{normal[s, 2]:.6f}"
        for s in range(n)
    ]
    (d / "bore.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    return d / "bore.csv"


def _run_on(d, points, feature, *extra):
    return runner.invoke(
        app,
        [
            "task", "uncertainty", str(points), "--machine", MACHINE.name,
            "--params", str(d / "params.json"), "--feature", feature,
            "--unexplained", str(d / "E.json"), *_statement(extra), *extra,
        ],
    )  # fmt: skip


def test_circle_gives_diameter_and_roundness_and_tolerances_the_diameter(tmp_path):
    """A bore probed from inside: D = 2R + d_tip; the form output is the LS roundness."""
    d = _files(tmp_path)
    bore = _bore_points(d)
    result = _run_on(d, bore, "circle", "--tip-diameter", "2", "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    names = [o["name"] for o in doc["outputs"]]
    assert names == ["circle_diameter", "roundness"]
    q = np.array(doc["points"]["compensated"])
    radius = np.linalg.norm(q[:, :2] - q[:, :2].mean(axis=0), axis=1).mean()
    assert doc["outputs"][0]["value"] == pytest.approx(2 * radius + 2.0, abs=1e-6)
    assert doc["outputs"][0]["value"] == pytest.approx(40.0 + 2.0, abs=0.01)  # δ: some µm
    shaft = json.loads(
        _run_on(d, bore, "circle", "--tip-diameter", "2", "--side", "outer", "--json").stdout
    )
    assert doc["outputs"][0]["value"] - shaft["outputs"][0]["value"] == pytest.approx(4.0)
    value = doc["outputs"][1]["value"]
    toleranced = _run_on(
        d, bore, "circle", "--tolerance", f"0,,{value + 0.5}", "--tolerance-output", "roundness",
        "--json",
    )  # fmt: skip
    assert toleranced.exit_code == 0, toleranced.output
    assert json.loads(toleranced.stdout)["decision"]["decision"] == "conformance"


def test_plane_flatness_and_monte_carlo_validation(tmp_path):
    d = _files(tmp_path)
    plane = _bore_points(d, plane=True)
    result = _run_on(
        d, plane, "plane", "--method", "both", "--trials", "20000", "--seed", "4", "--json"
    )
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["method"] == "both" and [o["name"] for o in doc["outputs"]] == ["flatness"]
    assert doc["mcm"]["trials"] == 20_000
    # The LS flatness of noisy points is biased upward: the GUF of a peak-to-valley
    # cannot be validated (JCGM 101:2008, 8), and the document says so.
    assert doc["validation"]["passed"] is False
    assert doc["outputs"][0]["value"] > doc["guf"]["outputs"][0]["value"]


def test_points_of_a_length_and_a_sampled_simulator(tmp_path):
    """--feature points: the compensated coordinates (Sepahi Boroujeni (2021), Table 7-1)."""
    d = _files(tmp_path, cov_scale=0.0)  # parameters known exactly: E alone
    result = _run(
        d, "--unexplained", str(d / "E.json"), "--feature", "points", "--simulator", "sampled",
        "--draws", "2000", "--seed", "1", "--json",
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    names = [o["name"] for o in doc["outputs"]]
    assert names == ["X_1", "Y_1", "Z_1", "X_2", "Y_2", "Z_2"]
    assert doc["covariance_simulator"] == {"method": "sampled", "draws": 2000}
    assert [o["value"] for o in doc["outputs"]] == pytest.approx(
        np.ravel(doc["points"]["compensated"]), abs=1e-12
    )
    u_x1 = doc["outputs"][0]["u"]
    assert u_x1 == pytest.approx(np.sqrt(E_COV[0][0]) * UM, rel=1e-9)  # E alone, no v


@pytest.mark.parametrize(
    ("feature", "extra", "n", "named"),
    [
        # a sphere needs 4 points
        ("sphere", [], 3, "{points}: a sphere needs at least 4 points (least-squares), got 3"),
        ("circle", [], 2, "{points}: a circle needs at least 3 points (least-squares), got 2"),
        # a plane has no side
        ("plane", ["--side", "inner"], 8, "--side applies to a sphere, circle or cylinder"),
        # without --tolerance
        ("circle", ["--tolerance-output", "roundness"], 8, "--tolerance-output needs --tolerance"),
        ("circle", ["--tolerance", "0,,1", "--tolerance-output", "flatness"], 8,
         "--tolerance-output: 'flatness' is not an output"),
        ("circle", ["--method", "mcm", "--simulator", "sampled", "--draws", "5"], 8,
         "draws: the sampled simulator needs at least"),
        # a minimum-zone plane needs 4 contacts
        ("plane", ["--form", "minimum-zone"], 3,
         "{points}: a plane needs at least 4 points (minimum-zone), got 3"),
        # a length has no form
        ("length", ["--form", "minimum-zone"], 2, "--form minimum-zone applies to a form error"),
        ("cylinder", [], 4, "{points}: a cylinder needs at least 5 points (least-squares), got 4"),
    ],
)  # fmt: skip
def test_bad_feature_requests_exit_2_and_write_nothing(tmp_path, feature, extra, n, named):
    d = _files(tmp_path)
    points = _bore_points(d, n=n)
    out = d / "out.json"
    result = _run_on(d, points, feature, *extra, "-o", str(out))
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: " + named.format(points=points))
    assert not out.exists()


def _cylinder_points(d, n=12, radius=20.0, rng_seed=5):
    """A Ø 40 mm bore along Z (two rows of points, 30 mm apart) with 2 µm of form."""
    rng = np.random.default_rng(rng_seed)
    t = np.linspace(0, 2 * np.pi, n // 2, endpoint=False)
    t = np.concatenate([t, t + np.pi / n])
    z = np.repeat([80.0, 110.0], n // 2)
    r = radius + rng.normal(0, 0.002, n)
    pts = np.column_stack([r * np.cos(t), r * np.sin(t), z])
    q = MACHINE.inverse(pts, np.zeros((n, 6)))
    rows = ["point,X,Y,Z,B,C"] + [
        f"p{s + 1},{q[s, 0]:.6f},{q[s, 1]:.6f},{q[s, 2]:.6f},0,0" for s in range(n)
    ]
    (d / "cylinder.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    return d / "cylinder.csv"


def test_cylinder_diameter_cylindricity_and_minimum_zone_form(tmp_path):
    d = _files(tmp_path)
    points = _cylinder_points(d)
    ls = json.loads(_run_on(d, points, "cylinder", "--tip-diameter", "2", "--json").stdout)
    assert [o["name"] for o in ls["outputs"]] == ["cylinder_diameter", "cylindricity"]
    assert ls["outputs"][0]["value"] == pytest.approx(42.0, abs=0.01)  # bore: 2R + d_tip
    result = _run_on(d, points, "cylinder", "--form", "minimum-zone", "--json")
    assert result.exit_code == 0, result.output
    mz = json.loads(result.stdout)
    assert [o["name"] for o in mz["outputs"]] == ["cylinder_diameter", "minimum_zone_cylindricity"]
    # The minimum zone never exceeds the least-squares peak-to-valley (ISO 1101).
    assert 0 < mz["outputs"][1]["value"] <= ls["outputs"][1]["value"] + 1e-12
    assert mz["outputs"][1]["u"] > 0


def test_centres_are_positions_with_their_uncertainty(tmp_path):
    d = _files(tmp_path, cov_scale=0.0)  # parameters known exactly: E alone
    bore = _bore_points(d)
    result = _run_on(d, bore, "circle-centre", "--json")
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    names = [o["name"] for o in doc["outputs"]]
    assert names == ["circle_centre_x", "circle_centre_y", "circle_centre_z"]
    q = np.array(doc["points"]["compensated"])
    assert [o["value"] for o in doc["outputs"]] == pytest.approx(q.mean(axis=0), abs=1e-3)
    # n equally spaced points, independent e: x = (2/n) Σ cos θ_i e_r,i to first order, so
    # u²(x) = (4/n²) Σ cos²θ (cos²θ σ_xx + sin²θ σ_yy + sin 2θ σ_xy) = (3σ_xx + σ_yy)/(2n).
    u_x = np.sqrt((3 * E_COV[0][0] + E_COV[1][1]) / 16) * UM
    assert doc["outputs"][0]["u"] == pytest.approx(u_x, rel=1e-5)  # δ tilts by µrad


def test_the_calibrated_tool_compensates_the_task(tmp_path):
    """A parameter set with an identified tool vector (tool_mm): the task's compensated
    points are f(φ, δ̂) with that tool, not the machine's nominal one."""
    d = _files(tmp_path)
    pset = ParameterSet.load(d / "params.json", MACHINE)
    tool = MACHINE.tool + np.array([0.010, -0.020, 0.030])
    replace(pset, tool=tool).save(d / "params.json")
    result = _run(d, "--recalibrated", "--json")
    assert result.exit_code == 0, result.output
    q = MACHINE.readings_from_customary(
        {"X": [-138.565, -61.288], "Y": [94.656, 48.344], "Z": [196.232, 246.817],
         "B": [-42.0, -64.0], "C": [-293.0, -124.0]}
    )  # fmt: skip
    expected = MACHINE.forward(q, pset.values, tool=tool)
    np.testing.assert_allclose(json.loads(result.stdout)["points"]["compensated"], expected)
    assert np.abs(MACHINE.forward(q, pset.values) - expected).max() > 0.005  # it matters


def test_console_names_an_absent_repeatability_model_instead_of_a_zero_share(tmp_path):
    """Without --repeatability the console printed "repeatability 0.0 %" (issue 18 §3): the
    source is left out of the budget line and a note says what was used instead."""
    d = _files(tmp_path)
    result = _run(d, "--unexplained", str(d / "E.json"))
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    budget = next(ln for ln in lines if ln.startswith("  first-order budget: "))
    sources = [s.rsplit(" ", 2)[0] for s in budget.split(": ", 1)[1].split(", ")]
    assert sources == ["calibration", "unexplained volumetric error"]
    assert "  long-term variation of the parameters: recalibrated" in lines
    assert lines[-1] == (
        "no repeatability model given (--repeatability): the readings are taken as exact "
        "(zero reading covariance)"
    )
