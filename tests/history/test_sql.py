"""Tests for mtmetrology.history.sql: one SQL text, two drivers (sqlite3 and SQLAlchemy).

A SQLite file at the current revision is read and written through :mod:`sqlite3`; what it
writes must be what SQLAlchemy's ORM writes, byte for byte, and what the ORM wrote must
read back the same; any other database goes through SQLAlchemy (and Alembic) as before.
"""

from __future__ import annotations

import json
import sqlite3
import subprocess
import sys
from datetime import UTC, datetime, timedelta, timezone
from pathlib import Path

import pytest
from sqlalchemy import select
from sqlalchemy.orm import Session
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.errors import EnvironmentFailure, InputError
from mtmetrology.history import (
    add_result,
    database,
    list_runs,
    open_history,
    opening,
    schema,
    show_run,
    sql,
)
from mtmetrology.history.amendments import amend_run, show_amended
from mtmetrology.history.audit import AuditEntry, audit_entries
from mtmetrology.history.database import HEAD, schema_revision
from mtmetrology.kinematics.machine import Machine

MACHINE = Machine.load("five-axis-wcbxfzyst")
SRC = str(Path(__file__).resolve().parents[2] / "src")
#: Runs ``mtm`` as its console script does, then prints the loaded modules as JSON.
PROBE = (
    "import atexit, json, sys\n"
    "atexit.register(lambda: sys.__stderr__.write('MODULES ' + json.dumps(sorted(sys.modules))))\n"
    "from mtmetrology.__main__ import main\n"
    "main()\n"
)
#: An instant given with an offset and microseconds (the text form must keep both).
WHEN = datetime(2026, 3, 1, 8, 30, 5, 123456, tzinfo=timezone(timedelta(hours=1)))


def _added(path: Path, make_calibration, values=1.0):
    return add_result(
        str(path),
        make_calibration([values] * 13),
        MACHINE,
        performed_at=WHEN,
        note="spindle « changed »",
        artefact="SAMBA",
        temperature_c=20.25,
        serial="SN-1",
        by="ada",
    )


def _raw(path: Path, query: str) -> list[tuple]:
    with sqlite3.connect(path) as connection:
        return connection.execute(query).fetchall()


def test_a_sqlite_file_at_the_current_revision_is_opened_without_sqlalchemy(
    tmp_path, make_calibration
):
    db = tmp_path / "h.sqlite"
    open_history(db).dispose()
    with sql.connect(db, read_only=True) as history:
        assert isinstance(history, sql._Sqlite)
    with sql.connect(f"sqlite:///{db}?timeout=5") as history:  # not a plain file URL
        assert isinstance(history, sql._Engine)
    engine = open_history(db)
    with sql.connect(engine) as history:  # an engine is used as it is
        assert isinstance(history, sql._Engine) and history.engine is engine


def test_list_show_and_add_on_sqlite_import_no_sqlalchemy(tmp_path, make_calibration):
    """The three short commands, each in a fresh interpreter on a SQLite file at the
    current schema: SQLAlchemy, Alembic and SciPy are never imported, numpy by add only."""
    db = tmp_path / "h.sqlite"
    _added(db, make_calibration)
    amend_run(open_history(db), 1, {"operator": "bob"}, reason="forgotten", by="ada")
    new = tmp_path / "new.json"
    new.write_text(json.dumps(make_calibration([2.0] * 13)))
    lines = {
        "list": ["history", "list", "--db", str(db)],
        "show": ["history", "show", "1", "--db", str(db)],
        "add": ["history", "add", str(new), "--db", str(db), "--by", "ada"],
    }
    runs = {
        name: subprocess.Popen(
            [sys.executable, "-c", PROBE, *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env={"PYTHONPATH": SRC, "OMP_NUM_THREADS": "1", "PATH": ""},
        )
        for name, args in lines.items()
    }
    for name, run in runs.items():
        out, err = run.communicate(timeout=300)
        assert run.returncode == 0, err
        modules = set(json.loads(err.rpartition("MODULES ")[2]))
        assert {"sqlalchemy", "alembic", "scipy"}.isdisjoint(modules), name
        assert ("numpy" in modules) == (name == "add"), name  # add checks the parameter set
        if name == "show":
            assert "amended" in out and "'bob'" in out  # the amendments are shown
    assert [r.id for r in list_runs(open_history(db))] == [1, 2]


def test_rows_written_through_sqlite3_are_the_rows_the_orm_writes_and_reads(
    tmp_path, make_calibration
):
    """A run, its parameters, its machine and its audit row written through sqlite3: the
    ORM finds the run by its instant (the bound text is the stored text), reads the same
    values; the same run written by the ORM into another file is byte-identical, and
    sqlite3 reads that one back as the same record."""
    fast = tmp_path / "fast.sqlite"
    open_history(fast).dispose()
    record = _added(fast, make_calibration)
    engine = open_history(fast)
    with Session(engine) as session:
        (run,) = session.scalars(
            select(schema.CalibrationRun).where(schema.CalibrationRun.performed_at == WHEN)
        )
        assert run.performed_at == WHEN and run.recorded_at == record.recorded_at
        assert (run.result, run.input_hashes) == (record.result, record.input_hashes)
        assert run.residual_statistics == record.residual_statistics
        assert (run.temperature_c, run.artefact, run.operator_note) == (
            20.25,
            "SAMBA",
            record.operator_note,
        )
        parameters = session.scalars(
            select(schema.RunParameter).where(schema.RunParameter.run_id == run.id)
        ).all()
        assert [
            {"name": p.name, "unit": p.unit, "value": p.value, "u": p.u} for p in parameters
        ] == list(record.parameters)
        machine = session.get(schema.Machine, run.machine_id)
        assert (machine.name, machine.topology, machine.model, machine.serial) == (
            MACHINE.name,
            MACHINE.topology.string,
            "13",
            "SN-1",
        )
        (entry,) = audit_entries(session)
        at = session.scalars(select(AuditEntry.at)).one()
    assert (entry["actor"], entry["action"], entry["target"]) == ("ada", "add", "calibration run 1")
    assert entry["detail"]["content_sha256"] == record.content_sha256
    assert abs(at.replace(tzinfo=UTC) - record.recorded_at) < timedelta(seconds=5)
    assert show_run(engine, 1) == show_run(fast, 1) == record  # both drivers

    orm = tmp_path / "orm.sqlite"
    engine = open_history(orm)
    with Session(database.writer(engine)) as session, session.begin():
        session.add(
            schema.Machine(
                id=1, name=MACHINE.name, topology=MACHINE.topology.string, model="13", serial="SN-1"
            )
        )
        session.flush()
        session.add(
            schema.CalibrationRun(
                id=1,
                machine_id=1,
                kind=record.kind,
                performed_at=WHEN,
                performed_at_offset_min=60,
                recorded_at=record.recorded_at,
                software_version=record.software_version,
                operator_note=record.operator_note,
                artefact=record.artefact,
                temperature_c=record.temperature_c,
                residual_statistics=record.residual_statistics,
                input_hashes=record.input_hashes,
                result=record.result,
                content_sha256=record.content_sha256,
                parameter_vector=_raw(fast, "SELECT parameter_vector FROM calibration_runs")[0][0],
            )
        )
        session.flush()
        session.add_all(
            schema.RunParameter(run_id=1, position=k, **p) for k, p in enumerate(record.parameters)
        )
    for table in ("machines", "calibration_runs", "run_parameters"):
        assert _raw(orm, f"SELECT * FROM {table}") == _raw(fast, f"SELECT * FROM {table}"), table
    assert show_run(orm, 1) == record  # written by the ORM, read through sqlite3


def test_amendments_written_by_the_orm_are_shown_by_both_drivers(history_url, make_calibration):
    engine = open_history(history_url)
    add_result(engine, make_calibration([1.0] * 13), MACHINE, performed_at=WHEN, by="ada")
    amend_run(
        engine,
        1,
        {"performed_at": WHEN + timedelta(days=1), "temperature_c": 20.5, "operator": "bob"},
        reason="typo",
        by="ada",
    )
    record, amendments = show_amended(history_url, 1)  # sqlite3 on SQLite, text() on PostgreSQL
    assert (record, amendments) == show_amended(engine, 1)
    assert [(a.field, a.old_value, a.new_value) for a in amendments] == [
        (
            "performed_at",
            WHEN.astimezone(UTC).isoformat(),
            (WHEN + timedelta(days=1)).astimezone(UTC).isoformat(),
        ),
        ("temperature_c", None, 20.5),
        ("operator", None, "bob"),
    ]
    assert all(a.amended_at.tzinfo is UTC for a in amendments)
    assert record.performed_at == WHEN + timedelta(days=1) and record.temperature_c == 20.5


def test_an_older_schema_is_refused_by_a_reader_and_migrated_by_add(tmp_path, make_calibration):
    """The revision differs: SQLAlchemy and Alembic take over, as before the fast path."""
    db = tmp_path / "old.sqlite"
    open_history(db, revision="0004").dispose()
    with pytest.raises(
        InputError,
        match=rf"^database {db}: schema revision 0004, this mtmetrology reads {HEAD}; upgrade",
    ):
        list_runs(db)
    result = CliRunner().invoke(app, ["history", "list", "--db", str(db)])
    assert result.exit_code == 2
    assert _raw(db, "SELECT version_num FROM alembic_version") == [("0004",)]
    record = _added(db, make_calibration)
    assert _raw(db, "SELECT version_num FROM alembic_version") == [(HEAD,)]
    assert [r.id for r in list_runs(db)] == [record.id] == [1]
    fresh = tmp_path / "new.sqlite"  # a new file is given the schema by either
    assert list_runs(fresh) == () and schema_revision(open_history(fresh)) == HEAD


def _one_line(result, code: int) -> str:
    assert result.exit_code == code, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    return lines[0]


def test_a_sqlite3_fault_is_the_refusal_sqlalchemy_gives(tmp_path, make_calibration, monkeypatch):
    """A table dropped (exit 2) and a write lock held past the busy timeout (exit 3): the
    same one-line refusal, naming the file, from either driver."""
    db = tmp_path / "h.sqlite"
    _added(db, make_calibration)
    with sqlite3.connect(db) as connection:
        connection.execute("DROP TABLE amendments")
    with pytest.raises(InputError) as fast:
        show_amended(db, 1)
    with pytest.raises(InputError) as slow:
        show_amended(open_history(db), 1)
    assert (
        str(fast.value)
        == str(slow.value)
        == (
            f"database {db}: a table of the history is missing (the database was altered) "
            "(no such table: amendments)"
        )
    )
    line = _one_line(CliRunner().invoke(app, ["history", "show", "1", "--db", str(db)]), 2)
    assert line == f"error: {fast.value}"

    monkeypatch.setattr(opening, "BUSY_TIMEOUT_S", 0.05)
    monkeypatch.setattr(database, "BUSY_TIMEOUT_S", 0.05)
    engine = open_history(db)
    holder = sqlite3.connect(db, isolation_level=None)
    holder.execute("BEGIN IMMEDIATE")
    try:
        document = make_calibration([2.0] * 13)
        with pytest.raises(EnvironmentFailure) as fast:
            add_result(db, document, MACHINE, by="ada")
        with pytest.raises(EnvironmentFailure) as slow:
            add_result(engine, document, MACHINE, by="ada")
        assert (
            str(fast.value)
            == str(slow.value)
            == (
                f"database {db}: locked by another process beyond the busy timeout "
                "(database is locked)"
            )
        )
        path = tmp_path / "new.json"
        path.write_text(json.dumps(document))
        cli = CliRunner().invoke(app, ["history", "add", str(path), "--db", str(db)])
        assert _one_line(cli, 3) == f"error: {fast.value}"
    finally:
        holder.rollback()
        holder.close()
    assert [r.id for r in list_runs(db)] == [1]


def test_a_violated_constraint_other_than_a_duplicate_is_one_refusal(tmp_path, make_calibration):
    db = tmp_path / "h.sqlite"
    _added(db, make_calibration)
    with sqlite3.connect(db) as connection:  # a constraint the history does not know of
        connection.execute("CREATE UNIQUE INDEX one_note ON calibration_runs (operator_note)")
    with pytest.raises(InputError) as fast:
        _added(db, make_calibration, 2.0)
    assert str(fast.value) == (
        f"database {db}: a constraint of the history fails "
        "(UNIQUE constraint failed: calibration_runs.operator_note)"
    )
    assert [r.id for r in list_runs(db)] == [1]
    assert len(_raw(db, "SELECT * FROM audit_log")) == 1
