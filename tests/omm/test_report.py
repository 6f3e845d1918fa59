"""OMM results show themselves in a notebook as the report shows them (one renderer each)."""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.fitting.features import GaugeLength
from mtmetrology.formatting import format_uncertainty
from mtmetrology.kinematics.machine import Machine
from mtmetrology.omm.hysteresis import hysteresis_errors
from mtmetrology.omm.repeatability_records import fit_repeatability_file
from mtmetrology.omm.task import task_uncertainty
from mtmetrology.report import Report
from mtmetrology.report.results import add_result
from mtmetrology.uncertainty.conformity import Tolerance, decide
from mtmetrology.units import from_internal, to_internal

MACHINE = Machine.load("five-axis-wcbxfzyst")
UM = to_internal(1.0, "µm")
# Table 7-1 readings of the gauge-block task (X, Y, Z mm; B, C deg).
READINGS = MACHINE.readings_from_customary(
    {
        "X": [-138.5650, -61.2880],
        "Y": [94.6560, 48.3440],
        "Z": [196.2320, 246.8170],
        "B": [-42.0, -64.0],
        "C": [-293.0, -124.0],
    }
)
HEADER = "target,phi,theta,B,C,X_T,Y_T,Z_T,i,j,k,X,Y,Z,time"


def _sections(html: str) -> list[tuple[str, list[list[str]]]]:
    """(heading, table cells) of every report section; figures (SVG ids) are left out."""
    html = html.split('id="provenance"')[0]
    out = []
    for heading, body in re.findall(
        r'<section class="mtm-section" id="s\d+">\s*<h2>(.*?)</h2>(.*?)</section>', html, re.S
    ):
        cells = [re.findall(r"<t[hd][^>]*>(.*?)</t[hd]>", row) for row in re.findall(
            r"<tr>(.*?)</tr>", body, re.S
        )]  # fmt: skip
        texts = re.findall(r"<p>(.*?)</p>", body, re.S)
        out.append((heading, [*cells, texts]))
    return out


def _task():
    rng = np.random.default_rng(6)
    delta = rng.normal(0, 1, MACHINE.n_params) * MACHINE.parameter_scales * 5
    a = MACHINE.parameter_scales[:, None] * rng.normal(size=(13, 13)) * 2
    v = np.zeros((2, 6, 6))
    v[:, :3, :3] = np.diag([0.5, 0.6, 0.4]) * UM**2
    length = GaugeLength(tip_diameter=2 * MACHINE.tip_radius)
    result = task_uncertainty(MACHINE, READINGS, delta, a @ a.T, length, reading_covariance=v)
    out = result.result.outputs[0]
    tol = Tolerance(round(float(out.value), 1), -0.5, 0.5)
    return replace(result, decision=decide(out.value, out.U, tol, unit="mm"))


def test_task_result_notebook_shows_the_report_sections():
    result = _task()
    notebook = _sections(result._repr_html_())
    report = _sections(add_result(Report("Task uncertainty"), result).html())
    assert notebook == report
    headings = [h for h, _ in notebook]
    assert headings[0] == "Result" and headings[1] == "Budget by source (first order)"
    assert headings[-1].startswith("Conformity decision of")
    # the output table gives u of every output in µm, GUM 7.2.6 digits
    rows = notebook[0][1][1:-1]
    us = [format_uncertainty(float(from_internal(o.u, "µm"))) + " µm" for o in result.guf.outputs]
    assert [row[2] for row in rows] == us
    # the budget lists every source once, in the result's order
    assert [row[0] for row in notebook[1][1][1:-1]] == [
        k.replace("long_term", "long-term").replace("_", " ") for k in result.shares
    ]


def _records(tmp_path, n_targets=45, touches=6):
    rng = np.random.default_rng(0)
    rows = [HEADER]
    for t in range(n_targets):
        phi, theta = rng.uniform(0, 90), rng.uniform(0, 360)
        b, c = rng.uniform(-90, 90), rng.uniform(-180, 180)
        x, y, z = rng.uniform(-200, 200, 3)
        sp, cp = np.sin(np.radians(phi)), np.cos(np.radians(phi))
        n = [sp * np.sin(np.radians(theta)), sp * np.cos(np.radians(theta)), cp]
        for s in range(touches):
            p = np.array([x, y, z]) + rng.normal(0, 0.001, 3)
            rows.append(
                f"T{t},{phi},{theta},{b},{c},{x},{y},{z},{-n[0]},{-n[1]},{-n[2]},"
                f"{p[0]:.6f},{p[1]:.6f},{p[2]:.6f},{s}"
            )
    path = tmp_path / "records.csv"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_repeatability_fit_notebook_shows_what_the_command_reports(tmp_path):
    records = _records(tmp_path)
    html = tmp_path / "r.html"
    args = ["repeatability", "fit", str(records), "-o", str(tmp_path / "r.json")]
    res = CliRunner().invoke(app, [*args, "--allow-few-targets", "--report", str(html)])
    assert res.exit_code == 0, res.output
    fit = fit_repeatability_file(records, allow_few_targets=True)
    notebook = _sections(fit._repr_html_())
    assert notebook == _sections(html.read_text(encoding="utf-8"))
    assert [h for h, _ in notebook] == ["Models", "Per-target statistics"]
    # every target of the file has its row of statistics, with its touches less the first
    targets = notebook[1][1][1:-1]
    assert [(row[0], row[1]) for row in targets] == [(f"T{t}", "5") for t in range(45)]


def test_hysteresis_notebook_shows_h_per_indexation():
    # exact: r(direct) = 10.000 mm, r(hysteresis) = 10.002 mm at every ψ gives H = 2 µm
    psi = np.repeat(np.radians([0.0, 90.0]), 6)
    affected = np.tile([True] * 3 + [False] * 3, 2)
    noise = np.tile([0.0, 1e-4, -1e-4], 4)
    r = np.where(affected, 10.002, 10.000) + noise
    result = hysteresis_errors(psi, r, affected)
    notebook = _sections(result._repr_html_())
    assert notebook == _sections(add_result(Report("Hysteresis"), result).html())
    rows = notebook[0][1][1:-1]
    assert [(row[0], float(row[1])) for row in rows] == [("0", 2.0), ("90", 2.0)]
