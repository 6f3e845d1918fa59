"""Tests for ``mtm uncertainty run`` (mtmetrology.cli.uncertainty)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "gum-h1-end-gauge.yaml"
runner = CliRunner()

LINEAR = """
kind: measurement-model
name: two lengths
inputs:
  - {name: a, value: 10.0, u: 0.3, unit: µm}
  - {name: b, value: 5.0, u: 0.4, unit: µm}
outputs:
  - {name: s, expression: "a + b", unit: µm}
  - {name: d, expression: "a - b", unit: µm}
"""


def _json(args):
    result = runner.invoke(app, ["uncertainty", "run", *args, "--json"])
    assert result.exit_code == 0, result.output
    return json.loads(result.output)


def test_guf_json_document_reproduces_gum_h1():
    """GUM H.1.6 at p = 0.99: u = 31.7 nm, ν_eff 16.7, k = 2.92, U = 93 nm."""
    doc = _json([str(EXAMPLE), "--p", "0.99"])
    assert doc["kind"] == "uncertainty-result" and doc["version"] == 2 and doc["method"] == "guf"
    (out,) = doc["outputs"]
    assert out["name"] == "l" and out["unit"] == "nm" and out["p"] == 0.99
    assert out["value"] == pytest.approx(50_000_838.6)
    assert out["u"] == pytest.approx(31.7, abs=0.05)
    assert out["k"] == pytest.approx(2.92, abs=0.005) and round(out["U"]) == 93
    assert out["interval"] == pytest.approx([out["value"] - out["U"], out["value"] + out["U"]])
    budget = {row["input"]: row for row in doc["guf"]["budget"]["l"]}
    assert budget["dtheta"]["contribution"] == pytest.approx(16.675, abs=1e-3)
    assert budget["alpha_s"]["dof"] is None  # infinite dof is null in JSON
    assert "validation" not in doc


def test_both_methods_include_mcm_and_validation(tmp_path):
    """A linear model with normal inputs: GUF exact, so the validation passes."""
    model = tmp_path / "linear.yaml"
    model.write_text(LINEAR, encoding="utf-8")
    doc = _json(
        [str(model), "--method", "both", "--trials", "200000", "--seed", "7", "--digits", "1"]
    )
    assert doc["method"] == "both"
    assert doc["outputs"] == doc["mcm"]["outputs"]
    assert [o["name"] for o in doc["guf"]["outputs"]] == ["s", "d"]
    assert [o["name"] for o in doc["outputs"]] == ["s", "d"]
    assert [o["unit"] for o in doc["outputs"]] == ["µm", "µm"]
    # u(s) = u(d) = 0.5 µm exactly; MCM with 2e5 trials within 1 % (s.e. 0.16 %).
    for o in doc["outputs"]:
        assert o["u"] == pytest.approx(0.5, rel=0.01)
    assert doc["validation"]["passed"] is True
    assert doc["mcm"]["trials"] == 200_000


def test_seeded_mcm_is_reproducible(tmp_path):
    model = tmp_path / "linear.yaml"
    model.write_text(LINEAR, encoding="utf-8")
    args = [str(model), "--method", "mcm", "--trials", "20000", "--seed", "3"]
    assert _json(args)["outputs"] == _json(args)["outputs"]


def test_rich_output_prints_budget_results_and_verdict():
    """The printed verdict follows the structured one: GUM H.1 at 10⁵ trials, p = 0.95,
    δ from two digits of u = 32 nm (δ = 0.5 nm) — the JSON says whether it passed, and the
    text prints exactly the matching verdict line (never a substring of the other)."""
    args = [str(EXAMPLE), "--method", "both", "--trials", "100000", "--seed", "1"]
    passed = _json(args)["validation"]["passed"]
    result = runner.invoke(app, ["uncertainty", "run", *args], env={"COLUMNS": "140"})
    assert result.exit_code == 0, result.output
    for text in ("Uncertainty budget of l in nm", "dtheta", "GUF results", "Monte Carlo results"):
        assert text in result.output
    verdicts = {
        line.split(" by Monte Carlo")[0].strip()
        for line in result.output.splitlines()
        if "by Monte Carlo (JCGM" in line
    }
    assert verdicts == {"GUF validated" if passed else "GUF NOT validated"}


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--trials", "100"], "trials and adaptive apply to the Monte Carlo method"),
        (["--method", "mcm", "--trials", "100", "--adaptive"], "either a number of trials or"),
        (["--p", "1.5"], "p (the coverage probability) must lie in (0, 1), got 1.5"),
    ],
)
def test_bad_options_exit_with_a_message(args, message):
    result = runner.invoke(app, ["uncertainty", "run", str(EXAMPLE), *args])
    assert result.exit_code == 2
    assert message in result.output


def test_bad_model_file_names_file_and_token(tmp_path):
    model = tmp_path / "evil.yaml"
    model.write_text(LINEAR.replace('"a + b"', "\"__import__('os').getcwd()\""), encoding="utf-8")
    result = runner.invoke(app, ["uncertainty", "run", str(model)])
    assert result.exit_code == 2
    assert "evil.yaml: output 's': call to '__import__' is not allowed" in result.output
    result = runner.invoke(app, ["uncertainty", "run", str(tmp_path / "none.yaml")])
    assert result.exit_code == 2 and "none.yaml: file not found" in result.output
