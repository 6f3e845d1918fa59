"""``mtm demo``: the folder it writes, the commands it prints, its report in a browser."""

from __future__ import annotations

import csv
import json
import re
import shlex
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import binom
from test_report_browser import check_page
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.formatting import overstated_digits
from mtmetrology.report import demo as demo_runner
from mtmetrology.report.demo import MARKER
from mtmetrology.uncertainty.coverage import DEFAULT_P, unstated_coverage

runner = CliRunner()


def report_text(page: Path) -> str:
    """The text a reader sees in a report: tags, styles, scripts and figures removed."""
    import html

    body = re.sub(r"(?s)<(style|script|svg)\b.*?</\1>", " ", page.read_text(encoding="utf-8"))
    return html.unescape(re.sub(r"<[^>]+>", " ", body))


@pytest.fixture(scope="module")
def demo_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo") / "mtm-demo"
    result = runner.invoke(app, ["demo", "--out", str(out)], env={"COLUMNS": "400"})
    assert result.exit_code == 0, result.output
    return out, result.stdout


def test_demo_writes_inputs_results_and_report(demo_run):
    out, _ = demo_run
    for name in (
        "samba/plan.csv",
        "samba/samba.yaml",
        "samba/indications.csv",
        "samba/params.json",
        "samba/truth.json",
        "samba/balls.yaml",
        "samba/poses.csv",
        "planning/ball-grid.yaml",
        "planning/programme.csv",
        "planning/plan.json",
        "gauge/gauge.csv",
        "gauge/length-check.json",
        "task/gauge-pair.csv",
        "task/unexplained.json",
        "task/gauge-length.json",
        "task/coverage.json",
        "prediction/gauge.csv",
        "prediction/gauge-xyz.csv",
        "uncertainty/gum-h1.yaml",
        "fitting/sphere.csv",
        "cmm/plate.yaml",
        "cmm/probes.yaml",
        "cmm/positions.yaml",
        "cmm/truth.yaml",
        "cmm/records.csv",
        "cmm/calibration.json",
        "cmm/gp.json",
        "report.html",
        MARKER,
    ):
        assert (out / name).is_file(), name
    params = json.loads((out / "samba" / "params.json").read_text(encoding="utf-8"))
    assert params["kind"] == "samba-calibration" and len(params["parameters"]) == 13
    assert "covariance" in params
    result = json.loads((out / "uncertainty" / "gum-h1-result.json").read_text(encoding="utf-8"))
    assert result["kind"] == "uncertainty-result" and "validation" in result
    (guf_out,) = result["guf"]["outputs"]
    assert round(guf_out["u"]) == 32  # GUM H.1.6: u_c(l) = 32 nm
    assert not [p for p in out.parent.iterdir() if p.name.startswith(".")]  # no work folder


def test_demo_plan_is_full_rank_and_its_programme_matches_the_plan(demo_run):
    """The planning section: two balls of the grid, full rank, and a programme CSV whose
    rows are the plan's (the printed `mtm samba plan` rewrites it: see the rerun test)."""
    out, _ = demo_run
    plan = json.loads((out / "planning" / "plan.json").read_text(encoding="utf-8"))
    assert plan["kind"] == "samba-design" and len(plan["balls"]) == 2
    assert plan["rank"] == plan["n_unknowns"]
    assert (
        plan["criterion"] == "D"
        and plan["step2"]["best_value"] >= plan["step2"]["best_start_value"]
    )  # DETMAX never lowers its criterion
    with (out / "planning" / "programme.csv").open(encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == plan["programme"]["columns"]
    assert len(rows) - 1 == plan["n_measurements"] == len(plan["programme"]["rows"])


def test_demo_samba_calibration_is_validated_and_covers_the_truth(demo_run):
    """The SAMBA section: GUF and adaptive MCM agree (JCGM 102), and the simulated truth
    lies inside the 95 % Monte Carlo intervals for at least 10 of the 13 parameters (for
    13 independent 95 % intervals P(at most 9 covered) = 0.3 %; the seed is fixed)."""
    out, stdout = demo_run
    result = json.loads((out / "samba" / "params.json").read_text(encoding="utf-8"))
    truth = json.loads((out / "samba" / "truth.json").read_text(encoding="utf-8"))
    true = {p["name"]: p["value"] for p in truth["parameters"]}
    assert result["kind"] == "samba-calibration"
    assert result["uncertainty"]["validation"]["passed"] is True
    mcm = result["uncertainty"]["mcm"]["outputs"]
    assert len(mcm) == 13 and {o["unit"] for o in mcm} == {"µm", "µrad", "µm/m"}
    covered = sum(o["interval"][0] <= true[o["name"]] <= o["interval"][1] for o in mcm)
    assert covered >= 10
    assert any(f"{covered}/13 true parameters" in line for line in stdout.splitlines())


def _iso_14253_decision(value: float, big_u: float, limits: dict) -> str:
    """ISO 14253-1:2017 with guard bands of U: conformance inside the limits shrunk by U,
    non-conformance outside the limits widened by U, undecided between."""
    if limits["lower_limit"] + big_u <= value <= limits["upper_limit"] - big_u:
        return "conformance"
    outside = value < limits["lower_limit"] - big_u or value > limits["upper_limit"] + big_u
    return "non-conformance" if outside else "undecided"


def test_demo_gauge_block_and_task_decision(demo_run):
    """Compensation cuts the gauge-block RMS length error (about 27 µm nominal) by more than
    five; the task decision is the ISO 14253-1 rule applied to the reported value and U."""
    out, _ = demo_run
    check = json.loads((out / "gauge" / "length-check.json").read_text(encoding="utf-8"))
    assert check["compensated"]["rms"] < check["nominal"]["rms"] / 5
    task = json.loads((out / "task" / "gauge-length.json").read_text(encoding="utf-8"))
    (length,) = task["outputs"]
    decision = task["decision"]
    limits = decision["tolerance"]
    assert decision["decision"] == _iso_14253_decision(length["value"], length["U"], limits)
    assert abs(length["value"] - limits["nominal"]) < 3 * length["U"]  # the truth is nominal


def test_demo_sphere_at_several_orientations(demo_run):
    """One points file per (B, C) in the ``mtm task uncertainty`` format (25 points with
    approach directions), one result per file whose decision is the ISO 14253-1 rule
    applied to its value and U, and a printed ``--feature sphere`` command."""
    out, stdout = demo_run
    csvs = sorted((out / "task").glob("sphere-*.csv"))
    assert len(csvs) >= 3
    orientations = set()
    for path in csvs:
        lines = path.read_text(encoding="utf-8").splitlines()
        header = lines[0].split(",")
        assert header[0] == "point" and {"X", "Y", "Z", "B", "C", "i", "j", "k"} <= set(header)
        rows = [line.split(",") for line in lines[1:]]
        assert len(rows) == 25
        b, c = (header.index(a) for a in ("B", "C"))
        assert len({(r[b], r[c]) for r in rows}) == 1  # one orientation per file
        orientations.add((rows[0][b], rows[0][c]))
        ijk = np.array([[float(r[header.index(a)]) for a in "ijk"] for r in rows])
        np.testing.assert_allclose(np.linalg.norm(ijk, axis=1), 1.0, atol=1e-6)
        result = json.loads(path.with_suffix(".json").read_text(encoding="utf-8"))
        diameter, sphericity = result["outputs"]  # as `--feature sphere` gives them
        assert diameter["name"] == "sphere_diameter" and diameter["unit"] == "mm"
        assert sphericity["name"] == "sphericity" and sphericity["value"] >= 0
        limits = result["decision"]["tolerance"]
        expected = _iso_14253_decision(diameter["value"], diameter["U"], limits)
        assert result["decision"]["decision"] == expected
    assert len(orientations) == len(csvs)
    sphere_commands = [
        line
        for line in stdout.splitlines()
        if "$ mtm task uncertainty" in line and "--feature sphere" in line
    ]
    assert len(sphere_commands) == 1
    # the printed command, written elsewhere, gives the demo's value, U and decision
    argv = shlex.split(sphere_commands[0].split("$ mtm ", 1)[1])
    written = argv[argv.index("-o") + 1]
    rerun = out.parent / "sphere-rerun.json"
    argv[argv.index("-o") + 1] = str(rerun)
    assert runner.invoke(app, argv).exit_code == 0
    demo, again = (json.loads(Path(f).read_text(encoding="utf-8")) for f in (written, rerun))
    assert (again["outputs"], again["decision"]) == (demo["outputs"], demo["decision"])
    rerun.unlink()


def test_demo_task_intervals_cover_the_truth(demo_run):
    """The coverage document counts the intervals value ± U that contain the simulated
    truth (25 mm sphere; the gauge block's end-face distance); recount from its fields.
    Binomial test at the 1 % level (fixed seed): fail when P(at most the count covered)
    < 1 % for independent 95 % intervals; with 16 tasks, 12 or fewer covered fails."""
    out, stdout = demo_run
    doc = json.loads((out / "task" / "coverage.json").read_text(encoding="utf-8"))
    assert doc["kind"] == "task-coverage" and doc["unit"] == "mm"
    tasks = doc["tasks"]
    assert doc["n_tasks"] == len(tasks) >= 10
    spheres = [t for t in tasks if t["feature"].startswith("sphere-")]
    gauges = [t for t in tasks if t["feature"].startswith("gauge-pair-")]
    assert len(spheres) + len(gauges) == len(tasks) and spheres and gauges
    assert {t["true"] for t in spheres} == {25.0}
    gauge_length = float(np.linalg.norm(np.array([200.0, 200.0, 0.0])))  # ends ±(100, 100)
    assert all(t["true"] == pytest.approx(gauge_length, abs=1e-9) for t in gauges)
    for t in spheres:  # the counted interval is the one of the written result
        result = json.loads((out / "task" / f"{t['feature']}.json").read_text(encoding="utf-8"))
        diameter = result["outputs"][0]
        assert (t["value"], t["U"]) == (diameter["value"], diameter["U"])
    covered = sum(abs(t["value"] - t["true"]) <= t["U"] for t in tasks)
    assert [t["covered"] for t in tasks] == [abs(t["value"] - t["true"]) <= t["U"] for t in tasks]
    assert doc["covered"] == covered
    p = doc["coverage_probability"]
    assert p == pytest.approx(DEFAULT_P)  # the coverage policy: k = 2, p = 2 Φ(2) − 1
    assert doc["binomial_p_at_most_covered"] == pytest.approx(binom.cdf(covered, len(tasks), p))
    assert binom.cdf(covered, len(tasks), p) >= 0.01
    assert any(
        line.startswith(f"- coverage: {covered}/{len(tasks)} ") for line in stdout.splitlines()
    )
    page = (out / "report.html").read_text(encoding="utf-8")
    for heading in (
        "A sphere measured at several orientations",
        "Coverage of the task intervals against the truth",
    ):
        assert re.search(rf"<h2[^>]*>{heading}</h2>", page), heading


def test_demo_cmm_section_compensates_the_held_out_position(demo_run):
    """On the held-out diagonal, both models cut the rms length error of the virtual CMM
    (about 3.2 µm) by more than half (the noise floor of a length is 0.5 µm · √2), and the
    report shows the calibration, the comparison plot and the GP."""
    out, stdout = demo_run
    comparison = json.loads((out / "cmm" / "comparison.json").read_text(encoding="utf-8"))
    rows = {r["model"].split()[0]: r for r in comparison["table"]}
    assert set(rows) == {"uncompensated", "kinematic", "GP"}
    for model in ("kinematic", "GP"):
        assert rows[model]["rms_error_um"] < 0.5 * rows["uncompensated"]["rms_error_um"]
        assert rows[model]["n_lengths"] == rows["uncompensated"]["n_lengths"] == 3 * 36
    calibration = json.loads((out / "cmm" / "calibration.json").read_text(encoding="utf-8"))
    assert calibration["kind"] == "ballplate-calibration"
    assert calibration["fit"]["rank"] == calibration["fit"]["n_unknowns"]
    page = (out / "report.html").read_text(encoding="utf-8")
    for heading in (
        "A bridge CMM calibrated on a ball plate",
        "Kinematic and GP models on a held-out plate position",
        "Training residuals",
    ):
        assert re.search(rf"<h2[^>]*>{heading}</h2>", page), heading
    assert any(line.startswith("- CMM ball plate:") for line in stdout.splitlines())


def test_demo_ends_with_the_report_path(demo_run):
    out, stdout = demo_run
    last = [line for line in stdout.splitlines() if line.strip()][-1]
    assert last == f"report: {out / 'report.html'}"


def test_printed_commands_rerun_and_rewrite_the_same_files(demo_run):
    """Every ``$ mtm ...`` the demo prints runs on the demo's files (one is meant to fail);
    a command that writes a file (``mtm predict -o``) rewrites the demo's file unchanged."""
    out, stdout = demo_run
    before = {p: p.read_bytes() for p in out.rglob("*.csv")}
    lines = [line for line in stdout.splitlines() if "$ mtm " in line]
    assert len(lines) >= 6 and any(" predict " in line for line in lines)
    overstated = []  # issue 31: every command's console follows the digits policy
    for line in lines:
        argv = shlex.split(line.split("$ mtm ", 1)[1])
        result = runner.invoke(app, argv, env={"COLUMNS": "400"})
        expected = 2 if "exits with code 2" in line else 0
        assert result.exit_code == expected, f"{line}\n{result.output}"
        overstated += overstated_digits(f"{result.stdout}\n{result.stderr}")
    assert {p: p.read_bytes() for p in out.rglob("*.csv")} == before
    assert overstated == []


def test_demo_states_k_beside_every_u_and_the_digits_u_allows(demo_run):
    """Issue 31: every result document the demo writes states k beside each U and U = k u,
    and neither its console nor its report prints more digits than u allows, a -0, a bare
    ± or a U without its k."""
    out, stdout = demo_run
    documents = sorted(out.rglob("*.json"))
    assert len(documents) >= 10
    unstated = {p.name: unstated_coverage(json.loads(p.read_text())) for p in documents}
    assert {name: e for name, e in unstated.items() if e} == {}
    # the samba calibration states the policy's k = 2 (p = 2 Φ(2) − 1) beside its U's
    samba = json.loads((out / "samba" / "params.json").read_text())
    assert samba["coverage"]["k"] == 2.0
    assert all(
        o["k"] == pytest.approx(2.0, abs=1e-9) for o in samba["uncertainty"]["guf"]["outputs"]
    )
    assert overstated_digits(stdout) == []
    assert overstated_digits(report_text(out / "report.html")) == []


def test_demo_report_in_the_browser(demo_run, browser, artefacts):
    out, _ = demo_run
    page = out / "report.html"
    n = len(re.findall(r'<figure class="mtm-figure"', page.read_text(encoding="utf-8")))
    assert n >= 8
    check_page(browser, page, n, artefacts, "mtm-demo")


def test_demo_refuses_a_folder_it_did_not_write(tmp_path):
    keep = tmp_path / "data"
    keep.mkdir()
    (keep / "precious.csv").write_text("x\n")
    result = runner.invoke(app, ["demo", "--out", str(keep)])
    assert result.exit_code == 2
    assert result.stderr == f"error: {keep} exists and is not a demo folder; choose another --out\n"
    assert [p.name for p in keep.iterdir()] == ["precious.csv"]


def test_interrupted_demo_leaves_nothing(tmp_path, monkeypatch):
    """The first example runs, the second writes a file and is interrupted (Ctrl-C)."""
    scripts = tmp_path / "examples"
    scripts.mkdir()
    stop = (
        "def main(ctx):\n    ctx.write_text('half', 'partial.txt')\n    raise KeyboardInterrupt\n"
    )
    (scripts / "stop.py").write_text(stop, encoding="utf-8")
    first = demo_runner.examples_folder() / demo_runner.EXAMPLES[0]
    monkeypatch.setattr(demo_runner, "EXAMPLES", [str(first), "stop.py"])
    monkeypatch.setattr(demo_runner, "examples_folder", lambda: scripts)
    out = tmp_path / "out" / "mtm-demo"
    result = runner.invoke(app, ["demo", "--out", str(out)])
    assert result.exit_code == 130 and result.stderr.strip() == "interrupted: nothing written"
    assert list(out.parent.iterdir()) == []


def test_demo_without_the_example_scripts_is_an_input_error(tmp_path, monkeypatch):
    """Installed without the repository's examples/ folder: one line, exit 2, no folder."""
    monkeypatch.setattr(demo_runner, "__file__", str(tmp_path / "a" / "b" / "c" / "demo.py"))
    out = tmp_path / "mtm-demo"
    result = runner.invoke(app, ["demo", "--out", str(out)])
    assert result.exit_code == 2 and not out.exists()
    folder = tmp_path / "examples"
    assert result.stderr == (
        f"error: the example scripts are not beside this installation (looked in {folder}); "
        "run from a clone of the repository\n"
    )
