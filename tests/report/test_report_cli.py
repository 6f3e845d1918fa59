"""``--report FILE.html`` on the commands that produce results."""

from __future__ import annotations

import json
import re

import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app

runner = CliRunner()


def _figures(page: str) -> int:
    return len(re.findall(r'<figure class="mtm-figure"', page))


def _provenance(page: str, key: str) -> str:
    return re.search(rf"<th scope=\"row\">{key}</th><td><code>(.*?)</code>", page).group(1)


def _cell_after(page: str, label: str) -> str:
    return re.search(rf"<td>{label}</td><td[^>]*>(.*?)</td>", page).group(1)


@pytest.fixture(scope="module")
def reports(report_commands, tmp_path_factory):
    """Every command run once with --report: {name: (result, page)}."""
    out = tmp_path_factory.mktemp("reports")
    done = {}
    for name, args in report_commands(out).items():
        result = runner.invoke(app, args)
        assert result.exit_code == 0, f"{name}: {result.output}"
        done[name] = result, (out / f"{name}.html").read_text(encoding="utf-8")
    return done


def test_uncertainty_run_report_with_validation_and_seed(reports):
    _, page = reports["uncertainty"]
    assert _figures(page) == 2  # budget bars, Monte Carlo histogram against the GUF
    assert _provenance(page, "seed") == "4"
    command = _provenance(page, "command")
    assert command.startswith("mtm uncertainty run ") and "--trials 20000 --seed 4" in command
    assert re.search(r"Validation of the GUF by Monte Carlo: (NOT )?validated</h2>", page)


def test_uncertainty_report_leaves_json_on_stdout(command_inputs, tmp_path):
    out = tmp_path / "r.html"
    args = ["uncertainty", "run", str(command_inputs["model"]), "--json", "--report", str(out)]
    result = runner.invoke(app, args)
    assert result.exit_code == 0
    assert json.loads(result.stdout)["kind"] == "uncertainty-result" and out.exists()


def test_fit_report_shows_parameters_and_deviations(reports):
    _, page = reports["fit"]
    assert _figures(page) == 2
    assert float(_cell_after(page, "r")) == pytest.approx(12.7, abs=1e-6)
    assert "sha256" in _provenance(page, "inputs")


def test_identifiability_report(reports, command_inputs):
    _, page = reports["identifiability"]
    assert _figures(page) == 1
    assert int(_cell_after(page, "indications")) == command_inputs["n_poses"]
    assert int(_cell_after(page, "rank")) == int(_cell_after(page, "unknowns"))


def test_predict_report_correction_of_a_location_error(reports):
    """A pure offset E_X0C = −104.6 µm moves every point by 104.6 µm (rotations keep norms)."""
    _, page = reports["predict"]
    assert float(_cell_after(page, "largest correction")) == pytest.approx(104.6, rel=1e-9)
    assert _figures(page) == 1  # the correction vectors (no covariance: no correlation map)


def test_bad_input_writes_no_report(tmp_path):
    out = tmp_path / "r.html"
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y\n1,2\n")
    result = runner.invoke(app, ["fit", "sphere", str(bad), "--report", str(out)])
    assert result.exit_code == 2 and not out.exists()


def test_unwritable_report_path_is_one_line_and_exit_2(command_inputs, tmp_path):
    (tmp_path / "a-file").write_text("")
    target = tmp_path / "a-file" / "r.html"
    result = runner.invoke(
        app, ["uncertainty", "run", str(command_inputs["model"]), "--report", str(target)]
    )
    assert result.exit_code == 2
    assert result.stderr.startswith("error: ") and len(result.stderr.splitlines()) == 1
