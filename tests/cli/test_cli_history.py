"""Tests for ``mtm history`` (mtmetrology.cli.history), on a SQLite file."""

from __future__ import annotations

import csv
import json
import os
import subprocess
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


def _one_line(result, code: int) -> str:
    assert result.exit_code == code, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    return lines[0]


def test_a_file_that_is_not_a_history_is_one_line_exit_2_and_left_untouched(tmp_path):
    """Random bytes, text, a truncated database: exit 2 naming the file and the fault, the
    file byte for byte as it was; the next command on a healthy database works."""
    healthy = tmp_path / "h.sqlite"
    paths, _ = _calibrations(tmp_path, 2)
    assert _mtm("history", "add", paths[0], "--db", healthy).exit_code == 0
    files = {
        "random.sqlite": np.random.default_rng(32).bytes(1000),
        "text.sqlite": b"machine,date\nm1,2026-01-01\n",
        "truncated.sqlite": healthy.read_bytes()[:3000],
    }
    faults = {
        "random.sqlite": "not a database (or a corrupted one)",
        "text.sqlite": "not a database (or a corrupted one)",
        "truncated.sqlite": "corrupted or truncated",
    }
    for name, content in files.items():
        path = tmp_path / name
        path.write_bytes(content)
        for args in (("list",), ("add", paths[1]), ("trend", "E_X0C", "--machine", "m")):
            line = _one_line(_mtm("history", *args, "--db", path), 2)
            assert line.startswith(f"error: database {path}: {faults[name]} ("), line
        assert path.read_bytes() == content
        assert sorted(p.name for p in tmp_path.glob(f"{name}*")) == [name]
    listed = json.loads(_mtm("history", "list", "--db", healthy, "--json").stdout)
    assert len(listed["runs"]) == 1


@pytest.fixture
def small_file_system(tmp_path):
    """A 512 KiB tmpfs at tmp_path/fs (needs root: mount), unmounted at the end."""
    where = tmp_path / "fs"
    where.mkdir()
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=512k", "tmpfs", str(where)], capture_output=True
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.decode().strip()}")
    try:
        yield where
    finally:
        subprocess.run(["umount", "-l", str(where)], capture_output=True)


def test_a_full_disk_and_a_read_only_file_system_are_exit_3_and_the_runs_survive(
    tmp_path, small_file_system
):
    """A real full disk (the tmpfs filled) and a real read-only file system (the tmpfs
    remounted read-only): ``history add`` is one line, exit 3, naming the fault (the
    read-only one is still listed); once the space is back the database holds exactly its
    earlier run and takes the next one."""
    db = small_file_system / "h.sqlite"
    paths, _ = _calibrations(tmp_path, 3)
    assert _mtm("history", "add", paths[0], "--db", db).exit_code == 0
    filler = small_file_system / "filler"
    fd = os.open(filler, os.O_WRONLY | os.O_CREAT)
    with pytest.raises(OSError, match="No space left"):
        while True:
            os.write(fd, b"\0" * 4096)
    os.close(fd)
    note = "x" * 200_000  # a run larger than what is left
    line = _one_line(_mtm("history", "add", paths[1], "--db", db, "--note", note), 3)
    assert line.startswith(f"error: database {db}: the disk is full ("), line
    filler.unlink()
    listed = json.loads(_mtm("history", "list", "--db", db, "--json").stdout)
    assert [r["id"] for r in listed["runs"]] == [1]
    subprocess.run(["mount", "-o", "remount,ro", str(small_file_system)], check=True)
    line = _one_line(_mtm("history", "add", paths[1], "--db", db), 3)
    assert line.startswith(f"error: database {db}: on a read-only file system ("), line
    listed = json.loads(_mtm("history", "list", "--db", db, "--json").stdout)  # still readable
    assert [r["id"] for r in listed["runs"]] == [1]
    subprocess.run(["mount", "-o", "remount,rw", str(small_file_system)], check=True)
    assert _mtm("history", "add", paths[2], "--db", db).exit_code == 0
    listed = json.loads(_mtm("history", "list", "--db", db, "--json").stdout)
    assert [r["id"] for r in listed["runs"]] == [1, 2]


def test_dates_several_files_and_one_machine_option(tmp_path):
    """--date with an offset is that instant (shown in its offset); several files are one
    call; covariance and export take --machine (the older positional form still works,
    and a disagreement between the two is refused)."""
    db = tmp_path / "h.sqlite"
    paths, _ = _calibrations(tmp_path, 4)
    r = _mtm("history", "add", paths[0], "--db", db, "--date", "2025-01-06T08:00+02:00", "--json")
    assert json.loads(r.stdout)["performed_at"] == "2025-01-06T08:00:00+02:00"
    r = _mtm("history", "add", *paths[1:], "--db", db, "--date", "2025-02-01", "--json")
    assert r.exit_code == 0, r.output
    added = json.loads(r.stdout)["runs"]
    assert [run["id"] for run in added] == [2, 3, 4]
    assert {run["performed_at"] for run in added} == {"2025-02-01T00:00:00+00:00"}
    since = _mtm("history", "list", "--db", db, "--since", "2025-01-06T08:00+01:00", "--json")
    assert [run["id"] for run in json.loads(since.stdout)["runs"]] == [2, 3, 4]
    by_option, by_argument = tmp_path / "a.json", tmp_path / "b.json"
    r = _mtm("history", "covariance", "--machine", MACHINE.name, "-o", by_option, "--db", db)
    assert r.exit_code == 0, r.output
    assert _mtm("history", "covariance", MACHINE.name, "-o", by_argument, "--db", db).exit_code == 0
    assert json.loads(by_option.read_text()) == json.loads(by_argument.read_text())
    out = tmp_path / "e.csv"
    assert (
        _mtm("history", "export", "--machine", MACHINE.name, "-o", out, "--db", db).exit_code == 0
    )
    assert len(out.read_text().splitlines()) == 5
    line = _one_line(
        _mtm("history", "export", "m1", "--machine", "m2", "-o", tmp_path / "x.csv", "--db", db), 2
    )
    assert line == "error: machine 'm1' and --machine 'm2': give one"


def test_trend_refuses_a_non_positive_mpe_and_names_a_since_past_the_last_run(tmp_path):
    db = _weekly(tmp_path, [0.0, 0.9, 1.1, 2.4, 2.6])
    for mpe in ("-8", "0", "-1"):
        line = _one_line(_mtm("history", "trend", "E_X0C", "--db", db, "--mpe", mpe), 2)
        assert line == f"error: --mpe {float(mpe):g}: a maximum permissible error is positive"
    line = _one_line(_mtm("history", "trend", "E_X0C", "--db", db, "--since", "2030-01-01"), 2)
    assert line == (
        f"error: --since 2030-01-01T00:00:00+00:00: no calibration of '{MACHINE.name}' on or "
        "after it"
    )
    line = _one_line(_mtm("history", "trend", "E_NOPE", "--db", db), 2)
    assert line.startswith("error: parameter 'E_NOPE': not a parameter of the runs of")


def test_long_term_history_names_its_database(tmp_path, monkeypatch):
    """history:MACHINE@DB reads that database, not $MTMETROLOGY_DB (absent here)."""
    monkeypatch.setenv("MTMETROLOGY_DB", str(tmp_path / "elsewhere.sqlite"))
    db = tmp_path / "lab.sqlite"
    paths, rows = _calibrations(tmp_path, 5)
    assert _mtm("history", "add", *paths, "--db", db).exit_code == 0
    loaded = load_parameters(Path(f"history:{MACHINE.name}@{db}"), MACHINE)
    f = MACHINE.parameter_scales
    np.testing.assert_allclose(loaded.covariance / np.outer(f, f), np.cov(rows, rowvar=False))
    assert not (tmp_path / "elsewhere.sqlite").exists()


def test_long_term_history_takes_a_database_url_through_the_path_option():
    """--long-term is a Path option (pathlib makes postgresql://h/db postgresql:/h/db): the
    URL after '@' is the one given, as its refusal shows."""
    from mtmetrology.errors import EnvironmentFailure

    with pytest.raises(EnvironmentFailure, match=r"^database postgresql://u@127\.0\.0\.1:1/x: "):
        load_parameters(Path(f"history:{MACHINE.name}@postgresql://u@127.0.0.1:1/x"), MACHINE)
