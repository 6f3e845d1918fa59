"""Tests for ``mtm history`` (mtmetrology.cli.history), on a SQLite file."""

from __future__ import annotations

import csv
import json
from datetime import date, timedelta
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.cli._history import load_parameters
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

runner = CliRunner()
MACHINE = Machine.load("five-axis-wcbxfzyst")


def _calibrations(tmp_path, n=4):
    rows = np.random.default_rng(3).normal(size=(n, 13))
    paths = []
    for k, row in enumerate(rows):
        path = tmp_path / f"cal{k}.json"
        ParameterSet(
            MACHINE.parameter_names,
            row * MACHINE.parameter_scales,
            MACHINE.parameter_units,
            machine=MACHINE.name,
            model="13",
        ).save(path)
        paths.append(path)
    return paths, rows


def _mtm(*args):
    return runner.invoke(app, [str(a) for a in args])


def test_add_list_show_trend_covariance_export(tmp_path):
    db = tmp_path / "h.sqlite"
    paths, rows = _calibrations(tmp_path)
    for k, path in enumerate(paths):
        r = _mtm(
            "history", "add", path, "--db", db, "--date", f"2026-02-0{k + 1}", "--note", f"d{k}"
        )
        assert r.exit_code == 0, r.output
    listed = json.loads(_mtm("history", "list", "--db", db, "--json").stdout)
    assert [run["operator_note"] for run in listed["runs"]] == ["d0", "d1", "d2", "d3"]
    shown = json.loads(_mtm("history", "show", "2", "--db", db, "--json").stdout)
    np.testing.assert_allclose([p["value"] for p in shown["parameters"]], rows[1], rtol=1e-12)
    trend = json.loads(_mtm("history", "trend", "E_X0C", "--db", db, "--json").stdout)
    j = MACHINE.parameter_names.index("E_X0C")
    np.testing.assert_allclose([run["value"] for run in trend["runs"]], rows[:, j], rtol=1e-12)
    cov = tmp_path / "COV.json"
    assert _mtm("history", "covariance", MACHINE.name, "-o", cov, "--db", db).exit_code == 0
    loaded = ParameterSet.load(cov, MACHINE)
    f = MACHINE.parameter_scales
    np.testing.assert_allclose(loaded.covariance / np.outer(f, f), np.cov(rows, rowvar=False))
    out = tmp_path / "e.csv"
    assert _mtm("history", "export", MACHINE.name, "-o", out, "--db", db).exit_code == 0
    with open(out, newline="") as fh:
        table = list(csv.DictReader(fh))
    np.testing.assert_allclose([float(t["E_X0C [µm]"]) for t in table], rows[:, j], rtol=1e-12)


def test_bad_inputs_are_one_line_and_exit_2_with_nothing_written(tmp_path):
    db = tmp_path / "h.sqlite"
    unknown = tmp_path / "fit.json"
    unknown.write_text(json.dumps({"kind": "fit-result", "version": 1, "machine": MACHINE.name}))
    paths, _ = _calibrations(tmp_path, 1)
    cov = tmp_path / "COV.json"
    cases = [
        (("history", "add", unknown, "--db", db), 2, f"error: {unknown}: kind: 'fit-result'"),
        (
            ("history", "add", paths[0], "--machine", "three-axis-xfyz", "--db", db),
            2,
            f"error: {paths[0]}: a result of machine 'five-axis-wcbxfzyst', not of machine "
            "'three-axis-xfyz' (--machine)",
        ),
        (
            ("history", "list", "--db", "postgresql://u@127.0.0.1:1/x"),
            3,
            "error: database postgresql://u@127.0.0.1:1/x: does not answer",
        ),
        (
            ("history", "covariance", "nope", "-o", cov, "--db", db),
            2,
            "error: machine 'nope': not in the history",
        ),
    ]
    for args, code, start in cases:
        r = _mtm(*args)
        assert r.exit_code == code, (args, r.output)
        lines = r.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith(start), r.stderr
    assert not cov.exists()
    assert json.loads(_mtm("history", "list", "--db", db, "--json").stdout)["runs"] == []


def test_trend_with_mpe_writes_drift_due_date_and_the_report(tmp_path):
    """A steady 0.2 µm/day drift of E_X0C: TREND.json carries the drift whose due date is
    where the prediction meets the MPE; the HTML report holds the chart (an inline SVG)."""
    db = tmp_path / "h.sqlite"
    j = MACHINE.parameter_names.index("E_X0C")
    scales = MACHINE.parameter_scales
    for k in range(8):
        row = np.zeros(13)
        row[j] = 0.2 * 7 * k  # µm, one calibration a week
        path = tmp_path / f"c{k}.json"
        ParameterSet(
            MACHINE.parameter_names,
            row * scales,
            MACHINE.parameter_units,
            np.diag((0.01 * scales) ** 2),
            machine=MACHINE.name,
            model="13",
        ).save(path)
        r = _mtm(
            "history",
            "add",
            path,
            "--db",
            db,
            "--date",
            (date(2026, 3, 2) + timedelta(days=7 * k)).isoformat(),
        )
        assert r.exit_code == 0, r.output
    out, html = tmp_path / "trend.json", tmp_path / "trend.html"
    r = _mtm("history", "trend", "E_X0C", "--db", db, "--mpe", "20", "-o", out, "--report", html)
    assert r.exit_code == 0, r.output
    drift = json.loads(out.read_text())["drift"]
    assert drift["slope_per_day"] == pytest.approx(0.2, rel=1e-3)
    # 9.8 µm on 2026-04-20, 0.2 µm/day: 20 µm 51 days later (u 0.01 µm: the same day)
    assert drift["due_date"].startswith("2026-06-10")
    assert "<svg" in html.read_text()


def _weekly(tmp_path, values, u=0.5):
    """A history database with one calibration a week whose E_X0C is ``values`` (µm)."""
    db = tmp_path / "w.sqlite"
    j = MACHINE.parameter_names.index("E_X0C")
    scales = MACHINE.parameter_scales
    for k, v in enumerate(values):
        row = np.zeros(13)
        row[j] = v
        path = tmp_path / f"w{k}.json"
        ParameterSet(
            MACHINE.parameter_names,
            row * scales,
            MACHINE.parameter_units,
            np.diag((u * scales) ** 2),
            machine=MACHINE.name,
            model="13",
        ).save(path)
        day = (date(2026, 3, 2) + timedelta(days=7 * k)).isoformat()
        assert _mtm("history", "add", path, "--db", db, "--date", day).exit_code == 0
    return db


def test_drift_marginalises_the_random_walk_under_the_stated_prior(tmp_path):
    """``mtm history drift --rw-prior`` is the library's fit_drift(prior=...) (same numbers
    in DRIFT.json), the slope's interval holds the slope, and with 4 runs the reference
    prior is refused (exit 2, one line naming --rw-prior) while half-cauchy answers."""
    from datetime import datetime

    from mtmetrology.history import fit_drift

    values = [0.0, 0.9, 1.1, 2.4, 2.6, 3.9]
    db = _weekly(tmp_path, values)
    dates = [datetime(2026, 3, 2) + timedelta(days=7 * k) for k in range(len(values))]
    for prior in ("reference", "half-cauchy"):
        out = tmp_path / f"{prior}.json"
        r = _mtm("history", "drift", "E_X0C", "--db", db, "--rw-prior", prior, "-o", out)
        assert r.exit_code == 0, r.output
        doc = json.loads(out.read_text())
        lib = fit_drift("E_X0C", "µm", dates, values, np.full(len(values), 0.5), prior=prior)
        assert doc["prior"] == prior
        assert doc["slope_per_day"] == pytest.approx(lib.slope, rel=1e-6)
        assert doc["slope_interval_per_day"] == pytest.approx(list(lib.slope_interval), rel=1e-6)
        lo, hi = doc["slope_interval_per_day"]
        assert lo < doc["slope_per_day"] < hi
    (tmp_path / "few").mkdir()
    few = _weekly(tmp_path / "few", values[:4])
    r = _mtm("history", "drift", "E_X0C", "--db", few)
    assert r.exit_code == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "--rw-prior half-cauchy" in lines[0]
    assert (
        _mtm("history", "drift", "E_X0C", "--db", few, "--rw-prior", "half-cauchy").exit_code == 0
    )
    r = _mtm("history", "drift", "E_X0C", "--db", db, "--rw-prior", "flat")
    assert r.exit_code == 2 and r.stderr.strip().startswith("error: --rw-prior 'flat'")


def test_task_uncertainty_takes_the_long_term_covariance_from_the_history(tmp_path, monkeypatch):
    """``mtm task uncertainty --long-term history:MACHINE`` gives the same result as the
    COV.json written by ``mtm history covariance`` (one statistic, two routes)."""
    db = tmp_path / "h.sqlite"
    monkeypatch.setenv("MTMETROLOGY_DB", str(db))
    paths, _ = _calibrations(tmp_path, 5)
    for k, path in enumerate(paths):
        assert _mtm("history", "add", path, "--date", f"2026-02-0{k + 1}").exit_code == 0
    cov = tmp_path / "COV.json"
    assert _mtm("history", "covariance", MACHINE.name, "-o", cov).exit_code == 0
    (tmp_path / "points.csv").write_text(
        "point,X,Y,Z,B,C,end\n"
        "p1,-138.5650,94.6560,196.2320,-42,-293,1\n"
        "p2,-61.2880,48.3440,246.8170,-64,-124,2\n"
    )
    (tmp_path / "E.json").write_text(
        json.dumps(
            {
                "kind": "unexplained-volumetric-error",
                "version": 1,
                "unit": "µm²",
                "covariance": [[4.0, 0.0, 0.0], [0.0, 4.0, 0.0], [0.0, 0.0, 4.0]],
            }
        )
    )
    outputs = []
    for long_term in (cov, f"history:{MACHINE.name}"):
        r = _mtm(
            "task",
            "uncertainty",
            tmp_path / "points.csv",
            "--machine",
            MACHINE.name,
            "--params",
            cov,
            "--long-term",
            long_term,
            "--feature",
            "length",
            "--unexplained",
            tmp_path / "E.json",
            "--json",
        )
        assert r.exit_code == 0, r.output
        outputs.append(json.loads(r.stdout)["outputs"])
    assert outputs[0] == outputs[1]
    from_history = load_parameters(Path(f"history:{MACHINE.name}"), MACHINE)
    from_file = ParameterSet.load(cov, MACHINE)
    np.testing.assert_allclose(from_history.covariance, from_file.covariance, rtol=1e-12)
    np.testing.assert_allclose(from_history.values, from_file.values, rtol=1e-12)
    assert from_history.covariance.any()
