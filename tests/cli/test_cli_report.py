"""``--report FILE.html`` on the commands that produce results."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.samba import SambaSetup, probing_sequence

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "gum-h1-end-gauge.yaml"
runner = CliRunner()
ARTEFACT = """kind: samba-artefact
balls:
  - {id: "1", diameter_mm: 12.7}
  - {id: "2", diameter_mm: 12.7}
  - {id: SB1, diameter_mm: 12.7}
  - {id: SB2, diameter_mm: 12.7}
scale_bar: {ends: [SB1, SB2], length_mm: 305.2105, u_mm: 0.0012}
"""


def _figures(page: str) -> int:
    return len(re.findall(r'<figure class="mtm-figure"', page))


def _provenance(page: str, key: str) -> str:
    return re.search(rf"<th scope=\"row\">{key}</th><td><code>(.*?)</code>", page).group(1)


def _cell_after(page: str, label: str) -> str:
    return re.search(rf"<td>{label}</td><td[^>]*>(.*?)</td>", page).group(1)


def test_uncertainty_run_report_with_validation_and_json_on_stdout(tmp_path):
    out = tmp_path / "h1.html"
    args = [
        "uncertainty",
        "run",
        str(EXAMPLE),
        "--method",
        "both",
        "--trials",
        "20000",
        "--seed",
        "4",
        "--json",
        "--report",
        str(out),
    ]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    page = out.read_text(encoding="utf-8")
    assert _figures(page) == 2  # budget bars, Monte Carlo histogram against the GUF
    assert _provenance(page, "seed") == "4"
    assert _provenance(page, "command").startswith("mtm uncertainty run ")
    assert "--trials 20000 --seed 4" in _provenance(page, "command")
    verdict = "validated" if doc["validation"]["passed"] else "NOT validated"
    assert f"Validation of the GUF by Monte Carlo: {verdict}</h2>" in page


def test_fit_report_shows_parameters_and_deviations(tmp_path):
    rng = np.random.default_rng(7)
    d = rng.standard_normal((20, 3))
    pts = 12.7 * d / np.linalg.norm(d, axis=1, keepdims=True)
    csv = tmp_path / "ball.csv"
    csv.write_text("x,y,z\n" + "\n".join(",".join(f"{v:.9f}" for v in p) for p in pts) + "\n")
    out = tmp_path / "fit.html"
    result = runner.invoke(app, ["fit", "sphere", str(csv), "--report", str(out)])
    assert result.exit_code == 0, result.output
    page = out.read_text(encoding="utf-8")
    assert _figures(page) == 2
    assert float(_cell_after(page, "r")) == pytest.approx(12.7, abs=1e-6)
    assert "sha256" in _provenance(page, "inputs")


def test_identifiability_report(tmp_path):
    m = Machine.load("five-axis-wcbxfzyst")
    setup = SambaSetup(
        balls={"1": (-80, -40, 100), "2": (80, 120, 150)},
        scale_bar={"SB1": (-152.60525, 0, 30), "SB2": (152.60525, 0, 30)},
    )
    pairs = [(b, c) for b in (-90, -45, 0, 45, 90) for c in range(0, 360, 60)]
    ids, q = probing_sequence(m, setup, pairs)
    rows = [
        f"{i}," + ",".join(f"{v:.6f}" for v in r)
        for i, r in zip(ids, m.readings_to_customary(q), strict=True)
    ]
    poses = tmp_path / "poses.csv"
    poses.write_text("ball,X,Y,Z,B,C,S\n" + "\n".join(rows) + "\n")
    (tmp_path / "a.yaml").write_text(ARTEFACT)
    out = tmp_path / "ident.html"
    args = [
        "machine",
        "identifiability",
        "five-axis-wcbxfzyst",
        str(poses),
        "--artefact",
        str(tmp_path / "a.yaml"),
        "--report",
        str(out),
    ]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    page = out.read_text(encoding="utf-8")
    assert _figures(page) == 1 and int(_cell_after(page, "indications")) == len(ids)
    assert int(_cell_after(page, "rank")) == int(_cell_after(page, "unknowns"))


def test_predict_report_correction_of_a_location_error(tmp_path):
    """A pure offset E_X0C = −104.6 µm moves every point by 104.6 µm (rotations keep norms)."""
    m = Machine.load("five-axis-wcbxfzyst")
    values = np.zeros(m.n_params)
    values[m.parameter_names.index("E_X0C")] = -0.1046
    ParameterSet(m.parameter_names, values, m.parameter_units, machine=m.name).save(
        tmp_path / "p.json"
    )
    rec = tmp_path / "rec.csv"
    rec.write_text("id,X,Y,Z,B,C\np1,-138.565,94.656,196.232,-42,-293\np2,10,20,30,15,40\n")
    out = tmp_path / "predict.html"
    args = [
        "predict",
        "--machine",
        "five-axis-wcbxfzyst",
        "--params",
        str(tmp_path / "p.json"),
        str(rec),
        "-o",
        str(tmp_path / "o.csv"),
        "--report",
        str(out),
    ]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    page = out.read_text(encoding="utf-8")
    assert float(_cell_after(page, "largest correction")) == pytest.approx(104.6, rel=1e-9)
    assert _figures(page) == 1  # correction vectors (a diagonal covariance-free set: no map)


def test_bad_input_writes_no_report(tmp_path):
    out = tmp_path / "r.html"
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y\n1,2\n")
    result = runner.invoke(app, ["fit", "sphere", str(bad), "--report", str(out)])
    assert result.exit_code == 2 and not out.exists()


def test_unwritable_report_path_is_one_line_and_exit_2(tmp_path):
    (tmp_path / "a-file").write_text("")
    result = runner.invoke(
        app, ["uncertainty", "run", str(EXAMPLE), "--report", str(tmp_path / "a-file" / "r.html")]
    )
    assert result.exit_code == 2
    assert result.stderr.startswith("error: ") and len(result.stderr.splitlines()) == 1
