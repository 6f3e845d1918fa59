"""Tests for mtmetrology.history.database: migrations, atomic adds, concurrent writers.

Each test runs on SQLite and on PostgreSQL (``history_url``, tests/history/conftest.py).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest
from sqlalchemy import inspect, text

from mtmetrology.errors import EnvironmentFailure, InputError
from mtmetrology.history import add_result, list_runs, open_history, show_run
from mtmetrology.history.database import (
    HEAD,
    HistoryUpgradeWarning,
    canonical_sha256,
    database_url,
    schema_revision,
)
from mtmetrology.kinematics.machine import Machine

MACHINE = Machine.load("five-axis-wcbxfzyst")
SRC = str(Path(__file__).resolve().parents[2] / "src")


def test_first_schema_version_upgrades_with_its_data_intact(history_url, make_calibration):
    """A database made at revision 0001, holding a run, is upgraded to the head: the run,
    its parameters and its document are unchanged, the hash (0002) and the parameter vector
    (0003) are filled from them."""
    engine = open_history(history_url, revision="0001")
    assert schema_revision(engine) == "0001"
    document = make_calibration(range(13))
    with engine.begin() as c:
        c.execute(
            text("INSERT INTO machines (id, name, model) VALUES (1, 'five-axis-wcbxfzyst', '13')")
        )
        c.execute(
            text(
                "INSERT INTO calibration_runs (id, machine_id, kind, performed_at, recorded_at, "
                "software_version, operator_note, residual_statistics, input_hashes, result) "
                "VALUES (1, 1, 'parameter-set', :t, :t, '0.0.9', 'before the upgrade', '{}', "
                "'{}', :doc)"
            ),
            {"t": datetime(2025, 5, 1, tzinfo=UTC), "doc": json.dumps(document)},
        )
        for k, entry in enumerate(document["parameters"]):
            c.execute(
                text(
                    "INSERT INTO run_parameters (run_id, position, name, unit, value, u) "
                    "VALUES (1, :k, :n, :unit, :v, :u)"
                ),
                {
                    "k": k,
                    "n": entry["name"],
                    "unit": entry["unit"],
                    "v": entry["value"],
                    "u": entry["u"],
                },
            )
    engine.dispose()
    engine = open_history(history_url)
    assert schema_revision(engine) == HEAD != "0001"
    record = show_run(engine, 1)
    assert record.operator_note == "before the upgrade"
    assert record.software_version == "0.0.9"
    assert record.result == document
    assert [p["value"] for p in record.parameters] == list(range(13))
    assert record.content_sha256 == canonical_sha256(document)
    with engine.connect() as c:  # 0003 filled the run's parameter vector from its rows
        vector = c.execute(text("SELECT parameter_vector FROM calibration_runs")).scalar()
    assert np.frombuffer(vector, dtype="<f8").tolist() == list(range(13))
    # the 0002 change holds: the same document cannot be recorded a second time
    with pytest.raises(InputError, match="already recorded as calibration run 1"):
        add_result(engine, document, MACHINE, by="test")


def test_a_database_that_does_not_answer_is_one_environment_failure():
    with pytest.raises(
        EnvironmentFailure, match=r"^database postgresql://u@127\.0\.0\.1:1/x: does not answer"
    ):
        open_history("postgresql://u@127.0.0.1:1/x")


def test_url_resolution_default_env_and_plain_path(tmp_path, monkeypatch):
    monkeypatch.delenv("MTMETROLOGY_DB", raising=False)
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "data"))
    assert database_url() == f"sqlite:///{tmp_path / 'data' / 'mtmetrology' / 'history.sqlite'}"
    monkeypatch.setenv("MTMETROLOGY_DB", str(tmp_path / "lab.sqlite"))
    assert database_url() == f"sqlite:///{tmp_path / 'lab.sqlite'}"
    assert database_url("postgresql://lab/h") == "postgresql://lab/h"
    with pytest.raises(InputError, match="not supported"):
        open_history("mysql://lab/h")


_CHILD = textwrap.dedent(
    """
    import sys, time
    from mtmetrology.history import add_result, open_history, records
    from mtmetrology.kinematics.machine import Machine
    import json

    url, document, pause = sys.argv[1], json.loads(sys.argv[2]), sys.argv[3] == "pause"
    open_history(url).dispose()
    if pause:
        def _stop(*args):  # the run and its parameters are written, the audit row is next
            print("in the transaction", flush=True)
            time.sleep(120)
        records.write_audit = _stop
    # the URL: a SQLite file at the current schema is written through sqlite3
    add_result(url, document, Machine.load("five-axis-wcbxfzyst"), by="test")
    """
)


def _child(url: str, document: dict, mode: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": SRC, "OMP_NUM_THREADS": "1"}
    return subprocess.Popen(
        [sys.executable, "-c", _CHILD, url, json.dumps(document), mode],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


def test_add_killed_inside_its_transaction_leaves_the_run_absent(history_url, make_calibration):
    """SIGKILL after the run and its parameters were flushed, before COMMIT: nothing of the
    run is left, and the next writer is not blocked."""
    engine = open_history(history_url)
    add_result(engine, make_calibration([1.0] * 13), MACHINE, by="test")
    child = _child(history_url, make_calibration([2.0] * 13), "pause")
    line = child.stdout.readline()
    assert line.strip() == "in the transaction", child.stderr.read()
    os.kill(child.pid, signal.SIGKILL)
    child.wait(timeout=30)
    assert child.returncode == -signal.SIGKILL
    assert [r.id for r in list_runs(engine)] == [1]
    with engine.connect() as c:
        assert c.execute(text("SELECT COUNT(*) FROM run_parameters")).scalar() == 13
    record = add_result(engine, make_calibration([3.0] * 13), MACHINE, by="test")
    assert [p["value"] for p in record.parameters] == [3.0] * 13


def test_two_concurrent_writers_lose_nothing(history_url, make_calibration):
    """Two processes adding 6 results each at the same time: all 12 are there, complete."""
    open_history(history_url).dispose()
    script = textwrap.dedent(
        """
        import sys, json
        from mtmetrology.history import add_result, open_history
        from mtmetrology.kinematics.machine import Machine
        engine, machine = open_history(sys.argv[1]), Machine.load("five-axis-wcbxfzyst")
        for document in json.loads(sys.argv[2]):
            add_result(engine, document, machine, by="test")
        """
    )
    env = {**os.environ, "PYTHONPATH": SRC, "OMP_NUM_THREADS": "1"}
    batches = [[make_calibration([10.0 * w + k] * 13) for k in range(6)] for w in range(2)]
    writers = [
        subprocess.Popen(
            [sys.executable, "-c", script, history_url, json.dumps(b)],
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        for b in batches
    ]
    for w in writers:
        assert w.wait(timeout=120) == 0, w.stderr.read()
    engine = open_history(history_url)
    runs = list_runs(engine)
    stored = sorted(show_run(engine, r.id).parameters[0]["value"] for r in runs)
    assert stored == sorted(10.0 * w + k for w in range(2) for k in range(6))
    with engine.connect() as c:
        assert c.execute(text("SELECT COUNT(*) FROM run_parameters")).scalar() == 12 * 13


def _insert_0001_run(connection, run_id: int, document: dict) -> None:
    """A calibration run and its parameters as schema 0001 stored them (no hash)."""
    connection.execute(
        text(
            "INSERT INTO calibration_runs (id, machine_id, kind, performed_at, recorded_at, "
            "software_version, residual_statistics, input_hashes, result) "
            "VALUES (:i, 1, 'parameter-set', :t, :t, '0.0.9', '{}', '{}', :doc)"
        ),
        {"i": run_id, "t": datetime(2025, 5, run_id, tzinfo=UTC), "doc": json.dumps(document)},
    )
    for k, entry in enumerate(document["parameters"]):
        connection.execute(
            text(
                "INSERT INTO run_parameters (run_id, position, name, unit, value, u) "
                "VALUES (:i, :k, :n, :unit, :v, :u)"
            ),
            {"i": run_id, "k": k, "n": entry["name"], "unit": entry["unit"], "v": entry["value"]}
            | {"u": entry["u"]},
        )


def test_a_first_schema_database_holding_a_result_twice_migrates(history_url, make_calibration):
    """Schema 0001 allowed the same result twice; the unique hash of 0002 does not. The
    upgrade keeps the first, moves the second (and its parameters) to duplicate_results
    and says so; before, it failed with IntegrityError on every command."""
    engine = open_history(history_url, revision="0001")
    twice, other = make_calibration([1.0] * 13), make_calibration([2.0] * 13)
    with engine.begin() as c:
        c.execute(
            text("INSERT INTO machines (id, name, model) VALUES (1, :n, '13')"), {"n": MACHINE.name}
        )
        for run_id, document in ((1, twice), (2, other), (3, twice)):
            _insert_0001_run(c, run_id, document)
    engine.dispose()
    with pytest.warns(
        HistoryUpgradeWarning, match=r"1 result\(s\) recorded twice in calibration_runs"
    ):
        engine = open_history(history_url)
    assert schema_revision(engine) == HEAD
    assert [r.id for r in list_runs(engine)] == [1, 2]
    assert show_run(engine, 1).result == twice
    with engine.connect() as c:
        assert c.execute(text("SELECT COUNT(*) FROM run_parameters")).scalar() == 2 * 13
        aside = c.execute(
            text("SELECT category, kept_id, duplicate_id, content_sha256 FROM duplicate_results")
        ).all()
    assert [tuple(row) for row in aside] == [("calibration", 1, 3, canonical_sha256(twice))]


def test_a_reader_never_migrates_and_a_writer_does(history_url):
    """A database at 0003: a reader refuses it naming the upgrade command and leaves it at
    0003; a writer (and mtm history upgrade) brings it to the head."""
    open_history(history_url, revision="0003").dispose()
    with pytest.raises(InputError, match=r"schema revision 0003, .* mtm history upgrade --db"):
        open_history(history_url, read_only=True)
    assert schema_revision(open_history(history_url, revision="0003")) == "0003"
    assert schema_revision(open_history(history_url)) == HEAD
    assert list_runs(open_history(history_url, read_only=True)) == ()


def test_a_schema_newer_than_this_version_is_refused_untouched(history_url):
    engine = open_history(history_url)
    with engine.begin() as c:
        c.execute(text("UPDATE alembic_version SET version_num = '9999'"))
    for read_only in (True, False):
        with pytest.raises(EnvironmentFailure, match=r"revision '9999' is newer than .* knows"):
            open_history(history_url, read_only=read_only)
    assert schema_revision(engine) == "9999"


def test_another_applications_database_is_refused_and_left_as_it_was(history_url):
    """Tables of another application and no alembic_version: no table of ours is created
    in it, by a reader or a writer."""
    engine = open_history(history_url, revision="0001")
    with engine.begin() as c:  # make it someone else's: only their table
        for table in ("alembic_version", "run_parameters", "task_results"):
            c.execute(text(f"DROP TABLE {table}"))
        for table in ("verification_results", "calibration_runs", "machines"):
            c.execute(text(f"DROP TABLE {table}"))
        c.execute(text("CREATE TABLE invoices (id INTEGER PRIMARY KEY, total REAL)"))
    for read_only in (True, False):
        with pytest.raises(InputError, match=r"not a calibration history \(.*: invoices\)"):
            open_history(history_url, read_only=read_only)
    with engine.connect() as c:
        assert "machines" not in inspect(c).get_table_names()


def test_a_held_write_transaction_does_not_delay_a_reader(history_url, make_calibration):
    """Another process holds the write lock (SQLite: BEGIN IMMEDIATE with a row inserted;
    PostgreSQL: the writers' and the migration's advisory locks and an uncommitted row):
    opening the database and listing its runs takes well under 1 s (it waited the 60 s busy
    timeout before: the migration check took the write lock)."""
    engine = open_history(history_url)
    add_result(engine, make_calibration([1.0] * 13), MACHINE, by="test")
    holder = _holder(history_url)
    try:
        start = time.perf_counter()
        runs = list_runs(open_history(history_url, read_only=True))
        reader = time.perf_counter() - start
        start = time.perf_counter()
        open_history(history_url).dispose()  # a writer at the head does not wait either
        opened = time.perf_counter() - start
    finally:
        holder.rollback()
        holder.close()
    assert [r.id for r in runs] == [1]
    assert reader < 1.0 and opened < 1.0, (reader, opened)


def _holder(url: str):
    """A connection of another client holding the write lock, uncommitted."""
    if url.startswith("sqlite"):
        import sqlite3

        connection = sqlite3.connect(url.removeprefix("sqlite:///"), isolation_level=None)
        connection.execute("BEGIN IMMEDIATE")
        connection.execute("INSERT INTO machines (name) VALUES ('held')")
        return connection
    import psycopg

    connection = psycopg.connect(url)
    connection.execute("SELECT pg_advisory_xact_lock(24024), pg_advisory_xact_lock(24025)")
    connection.execute("INSERT INTO machines (name) VALUES ('held')")
    return connection
