"""``--report FILE.html`` on the commands that produce results."""

from __future__ import annotations

import json
import math
import re

import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.formatting import format_uncertainty

runner = CliRunner()


def _two_digits(shown: float, value: float) -> bool:
    """``shown`` is ``value`` rounded to two significant digits (JCGM 100:2008, 7.2.6)."""
    last = 10.0 ** (math.floor(math.log10(abs(value))) - 1)
    return (
        abs(shown - value) <= 0.5 * last * (1 + 1e-9)
        and len(re.sub(r"^[0.]+", "", f"{shown:g}").replace(".", "")) <= 2
    )


def _figures(page: str) -> int:
    return len(re.findall(r'<figure class="mtm-figure"', page))


def _provenance(page: str, key: str) -> str:
    return re.search(rf"<th scope=\"row\">{key}</th><td><code>(.*?)</code>", page).group(1)


def _cell_after(page: str, label: str) -> str:
    return re.search(rf"<td>{label}</td><td[^>]*>(.*?)</td>", page).group(1)


@pytest.fixture(scope="module")
def reports(command_reports):
    """Every command run once with --report: {name: (result, page)}."""
    done = {}
    for name, (result, path) in command_reports.items():
        assert result.exit_code == 0, f"{name}: {result.output}"
        done[name] = result, path.read_text(encoding="utf-8")
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
    assert result.stderr.startswith(f"error: {bad}: missing column 'z'"), result.stderr


def test_unwritable_report_path_is_one_line_and_exit_2(command_inputs, tmp_path):
    (tmp_path / "a-file").write_text("")
    target = tmp_path / "a-file" / "r.html"
    result = runner.invoke(
        app, ["uncertainty", "run", str(command_inputs["model"]), "--report", str(target)]
    )
    assert result.exit_code == 2
    assert result.stderr.startswith(f"error: {target}: ") and len(result.stderr.splitlines()) == 1


# -- CMM ----------------------------------------------------------------------------------
def _cells(page: str, label: str) -> list[str]:
    """The cells of the table row whose first cell is ``label``."""
    row = re.search(rf"<tr><td>{re.escape(label)}</td>(.*?)</tr>", page, re.S).group(1)
    return re.findall(r"<td[^>]*>(.*?)</td>", row)


def test_ballplate_report_shows_parameters_datum_residuals_and_selection(
    reports, command_reports, command_inputs
):
    """Every figure (correlation, singular values, one residual map per position, the
    uncertainty map), a parameter row per identified parameter, U1–U3 as in the JSON
    result, the scores of --model auto with the model the JSON says was chosen."""
    _, page = reports["ballplate"]
    doc = json.loads(command_reports["ballplate"][1].with_suffix(".json").read_text())
    n_positions = command_inputs["n_plate_positions"]
    assert _figures(page) == 3 + n_positions
    assert (
        len(re.findall(r"<figcaption>Figure \d+\. Plate position \w+: residuals", page))
        == n_positions
    )
    for p in doc["parameters"]:
        assert re.search(rf"<tr><td>{re.escape(p['name'])}</td>", page), p["name"]
    assert int(_cell_after(page, "rank")) == int(_cell_after(page, "unknowns"))
    assert int(_cell_after(page, "unknowns")) == doc["fit"]["n_unknowns"]
    for row, key in (("u1: ball centres", "U1_um"), ("u3: whole volume", "U3_um")):
        shown = [float(v) for v in _cells(page, row)]
        assert all(_two_digits(a, b) for a, b in zip(shown, doc["uncertainty"][key], strict=True))
    chosen = doc["model_selection"]["chosen"]
    assert re.search(rf"<h2[^>]*>Model selection: {re.escape(chosen)}</h2>", page)
    for score in doc["model_selection"]["scores"]:
        name = score["model"] + (" (chosen)" if score["model"] == chosen else "")
        cells = _cells(page, name)  # median, mean, AIC, verdict, one cell per fold
        assert float(cells[0]) == pytest.approx(score["median_rms_um"], rel=5e-3)
        assert float(cells[1]) == pytest.approx(score["mean_rms_um"], rel=5e-3)
        assert len(cells) == 4 + len(doc["model_selection"]["positions"])
    assert re.search(r"<h2[^>]*>Datum</h2>", page)


def test_gp_fit_report_hyperparameters_and_training_residuals(reports, command_reports):
    _, page = reports["gp-fit"]
    doc = json.loads(command_reports["gp-fit"][1].with_name("gp.json").read_text())
    assert _figures(page) == 1  # the training residual vectors
    for comp in doc["components"]:
        cells = _cells(page, comp["component"])  # first table with that label: hyper-parameters
        assert float(cells[2]) == pytest.approx(comp["noise_um"], rel=5e-3)
    # the residuals of a GP that fitted its noise are of the size of that noise
    for comp in doc["components"]:
        rows = re.findall(rf"<tr><td>{comp['component']}</td>(.*?)</tr>", page, re.S)
        rms_residual = float(re.findall(r"<td[^>]*>(.*?)</td>", rows[1])[1])
        assert 0.5 * comp["noise_um"] < rms_residual < 1.5 * comp["noise_um"]


def test_ballplate_budget_report_has_its_bars(reports, command_reports):
    _, page = reports["ballplate-budget"]
    doc = json.loads(command_reports["ballplate-budget"][1].with_name("budget.json").read_text())
    assert _figures(page) == 1  # the budget bars of l_x
    assert re.search(r"<h2[^>]*>Uncertainty budget of l_x</h2>", page)
    items = [b["input"] for b in doc["budget"]["l_x"]]
    assert len(items) == 14  # 15 items; item 5 (refractive index) enters through 6–11
    for item in items:
        assert re.search(rf"<tr><td>{re.escape(item)}</td>", page), item


def test_ballplate_bad_probe_writes_neither_result_nor_report(command_inputs, tmp_path):
    bad = tmp_path / "bad.csv"
    lines = command_inputs["ballplate"].read_text().splitlines()
    lines[1] = lines[1].replace(",P0,", ",P9,").replace(",PX1,", ",P9,").replace(",PY1,", ",P9,")
    bad.write_text("\n".join(lines) + "\n")
    out, rep = tmp_path / "r.json", tmp_path / "r.html"
    args = ["cmm", "calibrate", str(bad), "--machine", "cmm-moving-bridge", "--plate",
            str(command_inputs["plate"]), "--probes", str(command_inputs["probes"]),
            "-o", str(out), "--report", str(rep)]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 2 and not out.exists() and not rep.exists()
    assert result.stderr.startswith(f"error: {bad}, line 2: probe 'P9'"), result.stderr
    assert result.stderr.startswith("error: ") and len(result.stderr.splitlines()) == 1


def test_model_comparison_renders_in_a_notebook():
    """``_repr_html_`` of a comparison: its table and the length-error figure; coverage as
    counted from the plot data (2 of 3 lengths of model b within ±2u)."""
    from mtmetrology.cmm.compare import ModelComparison

    plot = {
        "a": {"length_mm": [100.0, 200.0, 300.0], "error_um": [0.1, -0.2, 0.3], "u_um": [1, 1, 1]},
        "b": {"length_mm": [100.0, 200.0, 300.0], "error_um": [0.5, 3.0, -1.0], "u_um": [1, 1, 1]},
    }
    table = [
        {"model": m, "n_lengths": 3, "rms_error_um": 1.0, "max_error_um": 1.0, "mean_u_um": 1.0,
         "coverage": c, "coverage_factor": 2.0}
        for m, c in (("a", 1.0), ("b", 2 / 3))
    ]  # fmt: skip
    html = ModelComparison(table, plot)._repr_html_()
    assert _figures(html) == 1
    assert _cells(html, "b")[-1] == "67 %"
    assert "b: 67 % within ±2u" in html  # the panel title, drawn as SVG text


def test_gp_model_shows_in_a_notebook_what_its_report_shows(reports, command_reports):
    """The GP model read back from its file renders the report's tables and figure."""
    from mtmetrology.cmm.gp import GPErrorModel
    from mtmetrology.kinematics import Machine

    doc = json.loads(command_reports["gp-fit"][1].with_name("gp.json").read_text())
    html = GPErrorModel.from_document(doc, Machine.load("cmm-moving-bridge"))._repr_html_()
    _, page = reports["gp-fit"]
    assert _figures(html) == _figures(page) == 1
    for comp in ("x", "y", "z"):
        assert _cells(html, comp) == _cells(page, comp)


def _tables(page: str) -> list[tuple[list[str], list[list[str]]]]:
    """Every table of a page as (column headers, body rows of cell texts)."""
    out = []
    for table in re.findall(r"<table class=\"mtm-table\">(.*?)</table>", page, re.S):
        heads = re.findall(r"<th scope=\"col\">(.*?)</th>", table)
        body = re.search(r"<tbody>(.*?)</tbody>", table, re.S).group(1)
        rows = [re.findall(r"<td[^>]*>(.*?)</td>", r) for r in re.findall(r"<tr>(.*?)</tr>", body)]
        out.append((heads, rows))
    return out


def _table(page: str, *heads: str) -> list[list[str]]:
    """Body rows of the one table whose headers start with ``heads``."""
    (rows,) = [rows for h, rows in _tables(page) if tuple(h[: len(heads)]) == heads]
    return rows


def test_samba_calibration_report_shows_parameters_uncertainty_and_validation(
    reports, command_reports
):
    _, page = reports["samba-calibrate"]
    path = command_reports["samba-calibrate"][1]
    doc = json.loads((path.parent / "samba.json").read_text(encoding="utf-8"))
    names = [p["name"] for p in doc["parameters"]]
    # correlation map, singular values, residual vectors, one MC histogram per parameter
    assert _figures(page) == 3 + len(names)
    assert _provenance(page, "seed") == "3"
    assert int(_cell_after(page, "rank")) == doc["identification"]["rank"]
    rows = {r[0]: r for r in _table(page, "parameter", "value", "unit", "u")}
    assert list(rows) == names
    k = doc["coverage"]["k"]  # the one k of the document (the policy: k = 2)
    assert f"U (k = {k:.3g})" in _tables_with_head(page, "parameter", "value", "unit", "u")
    for p in doc["parameters"]:  # u and U = k u, rounded to two significant digits
        assert rows[p["name"]][2] == p["unit"]
        assert rows[p["name"]][3] == format_uncertainty(p["u"])
        assert rows[p["name"]][4] == format_uncertainty(k * p["u"])
    conventions = _table(page, "parameter", "unit", "axis", "positive value")
    assert [r[0] for r in conventions] == [c["name"] for c in doc["conventions"]]
    assert [r[3] for r in conventions] == [c["positive"] for c in doc["conventions"]]
    validation = doc["uncertainty"]["validation"]
    verdict = "validated" if validation["passed"] else "NOT validated"
    assert f"JCGM 102 validation of the GUF by Monte Carlo: {verdict}</h2>" in page
    table = _table(page, "parameter", "unit", "value GUF", "value MCM")
    assert [r[0] for r in table] == [t["name"] for t in validation["table"]]
    assert [r[-1] == "yes" for r in table] == [t["validated"] for t in validation["table"]]
    guf, mcm = _tables_with(page, "parameter", "value", "u", "U", "k")
    assert [r[0] for r in guf] == [r[0] for r in mcm] == names


def _tables_with_head(page: str, *heads: str) -> list[str]:
    """Column headers of the one table whose headers start with ``heads``."""
    (head,) = [h for h, _ in _tables(page) if tuple(h[: len(heads)]) == heads]
    return head


def _tables_with(page: str, *heads: str) -> list[list[list[str]]]:
    return [rows for h, rows in _tables(page) if tuple(h[: len(heads)]) == heads]


def test_samba_length_report_errors_before_and_after(reports, command_reports, command_inputs):
    _, page = reports["samba-verify-length"]
    path = command_reports["samba-verify-length"][1]
    doc = json.loads((path.parent / "gauge.json").read_text(encoding="utf-8"))
    assert _figures(page) == 1
    pairs = _table(page, "pair", "error, nominal (µm)")
    assert len(pairs) == command_inputs["gauge_pairs"] == len(doc["pairs"])
    for row, p in zip(pairs, doc["pairs"], strict=True):
        assert float(row[1]) == pytest.approx(p["error_nominal_um"], rel=5e-3, abs=1e-3)
        assert float(row[2]) == pytest.approx(p["error_compensated_um"], rel=5e-3, abs=1e-3)
    stats = {r[0]: r for r in _table(page, "model", "mean", "rms")}
    for name in ("nominal", "compensated"):
        assert float(stats[name][2]) == pytest.approx(doc[name]["rms"], rel=5e-3)
    # compensation helps: the compensated RMS is below 5 % of the nominal one
    assert float(stats["compensated"][2]) < 0.05 * float(stats["nominal"][2])


def test_samba_failing_renderer_writes_neither_report_nor_result(
    command_inputs, report_commands, tmp_path, monkeypatch
):
    import mtmetrology.samba.report as samba_report

    def broken(cal):
        raise RuntimeError("renderer failure")

    monkeypatch.setattr(samba_report, "indication_residuals", broken)
    args = report_commands(tmp_path)["samba-calibrate"]
    args[args.index("--uncertainty") + 1] = "none"
    result = runner.invoke(app, args)
    # a failing renderer is a bug (exit 1, reported as such), not a refused input
    assert result.exit_code == 1
    assert result.stderr.startswith("internal error: RuntimeError: renderer failure")
    assert not (tmp_path / "samba.json").exists()
    assert not (tmp_path / "samba-calibrate.html").exists()


def test_design_report_shows_the_plan_it_wrote(reports, tmp_path_factory):
    """The page states the programme's counts, the plan's rank and the predicted u of
    every parameter that --json gives for the same command and seed."""
    _, page = reports["design"]
    assert _figures(page) == 2  # DETMAX convergence of step 1 and step 2
    assert "--seed 5" in _provenance(page, "command")
    d = tmp_path_factory.mktemp("design-json")
    grid = re.search(r"--balls-from (\S+)", _provenance(page, "command")).group(1)
    args = ["samba", "plan", "--machine", "five-axis-wcbxfzyst", "--model", "13",
            "--balls-from", grid, "--n-balls", "2", "--k", "3", "--criterion", "D",
            "--starts", "2", "--seed", "5", "--b-grid", "-90:90:15", "--c-grid", "0:330:30",
            "-o", str(d / "programme.csv"), "--json"]  # fmt: skip
    doc = json.loads(runner.invoke(app, args).stdout)
    assert int(_cell_after(page, "indexations chosen")) == doc["n_indexations"]
    assert int(_cell_after(page, "ball measurements M_T")) == doc["n_measurements"]
    assert int(_cell_after(page, "rank")) == doc["rank"] == int(_cell_after(page, "unknowns"))
    duration = float(_cell_after(page, "estimated duration, h"))
    assert abs(duration - doc["duration_h"]) <= 0.05  # 0.1 h
    for p in doc["parameters"]:
        shown = re.search(rf"<td>{p['name']}</td><td[^>]*>(.*?)</td>", page).group(1)
        assert _two_digits(float(shown), p["u"]), p["name"]
    assert all(b["id"] in page for b in doc["balls"])
