"""Tests for ``mtm task uncertainty`` (mtmetrology.cli.task)."""

from __future__ import annotations

import json

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
    OutputFit,
    RepeatabilityModel,
    factors_from_file_units,
)
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


def _files(tmp_path, *, e_cov=E_COV, machine=MACHINE.name, z_high=260.0):
    (tmp_path / "points.csv").write_text(POINTS, encoding="utf-8")
    rng = np.random.default_rng(1)
    a = MACHINE.parameter_scales[:, None] * rng.normal(size=(13, 13))  # row i in its unit
    ParameterSet(
        MACHINE.parameter_names,
        rng.normal(size=13) * MACHINE.parameter_scales * 3,
        MACHINE.parameter_units,
        covariance=a @ a.T,
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
    return runner.invoke(app, [*base, *extra])


def test_length_with_unexplained_errors_only_matches_the_closed_form(tmp_path):
    d = _files(tmp_path)
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
    assert groups["repeatability"] > 0 and abs(groups["machine_parameters"]) < 1e-9
    u_e = first["outputs"][0]["u"]
    assert doc["outputs"][0]["u"] == pytest.approx(np.sqrt(u_e**2 + 2 * UM**2), rel=1e-6)
    assert doc["decision"]["decision"] == "conformance"


@pytest.mark.parametrize(
    ("files", "extra"),
    [
        ({"e_cov": E_PRINTED}, ["--unexplained", "E.json"]),  # eq. 6-15 as printed: not PSD
        ({"machine": "another-machine"}, []),  # parameter file of another machine
        ({"z_high": 200.0}, ["--repeatability", "R.json"]),  # Z = 246.8 mm outside the model
        ({}, ["--tolerance", "500,0.1,-0.1"]),
        ({}, ["--unexplained", "E.json", "--tip-diameter", "-1"]),
        ({}, []),  # no repeatability nor E: u would be 0
    ],
)
def test_bad_input_exits_2_with_one_line_and_writes_nothing(tmp_path, files, extra):
    d = _files(tmp_path, **files)
    extra = [str(d / x) if x.endswith(".json") else x for x in extra]
    out = d / "out.json"
    result = _run(d, *extra, "-o", str(out))
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ")
    assert not out.exists()


def test_three_points_for_a_length_are_refused(tmp_path):
    d = _files(tmp_path)
    (d / "points.csv").write_text(POINTS + "p3,0,0,0,0,0,1,0,0,2\n", encoding="utf-8")
    result = _run(d, "--unexplained", str(d / "E.json"))
    assert result.exit_code == 2 and result.stderr.startswith("error: ")


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
