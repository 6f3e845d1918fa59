"""Audited amendments (mtmetrology.history.amendments) on SQLite and PostgreSQL."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta, timezone

import pytest
from sqlalchemy import text
from sqlalchemy.exc import DBAPIError
from sqlalchemy.orm import Session

from mtmetrology.errors import InputError
from mtmetrology.history import add_result, list_runs, open_history
from mtmetrology.history.amendments import amend_run, original_values, show_amended
from mtmetrology.history.audit import audit_entries
from mtmetrology.kinematics.machine import Machine

MACHINE = Machine.load("five-axis-wcbxfzyst")


def _two_runs(engine, make_calibration):
    first = add_result(
        engine,
        make_calibration([1.0] * 13),
        MACHINE,
        performed_at=datetime(2026, 1, 5, tzinfo=UTC),
        note="first",
        temperature_c=20.1,
        by="test",
    )
    second = add_result(
        engine,
        make_calibration([2.0] * 13),
        MACHINE,
        performed_at=datetime(2026, 2, 5, tzinfo=UTC),
        by="test",
    )
    return first, second


def test_amend_keeps_the_original_and_reorders(history_url, make_calibration):
    engine = open_history(history_url)
    first, second = _two_runs(engine, make_calibration)
    # the second run was really measured before the first: the order of the runs follows
    new_date = datetime(2025, 12, 1, 9, 30, tzinfo=timezone(timedelta(hours=2)))
    made = amend_run(
        engine,
        second.id,
        {"performed_at": new_date, "operator": "A. Lovelace"},
        reason="date of the measurement, not of the upload",
        by="ada",
    )
    assert [a.field for a in made] == ["performed_at", "operator"]
    assert [r.id for r in list_runs(engine)] == [second.id, first.id]
    record, amendments = show_amended(engine, second.id)
    assert record.performed_at == new_date  # the same instant on both backends
    assert original_values(amendments) == {
        "performed_at": datetime(2026, 2, 5, tzinfo=UTC).isoformat(),
        "operator": None,
    }
    amend_run(engine, first.id, {"temperature_c": 20.4, "operator_note": "x"}, reason="r", by="b")
    amend_run(engine, first.id, {"temperature_c": 20.6}, reason="again", by="c")
    record, amendments = show_amended(engine, first.id)
    assert record.temperature_c == 20.6 and record.operator_note == "x"
    assert original_values(amendments) == {"temperature_c": 20.1, "operator_note": "first"}
    with Session(engine) as session:
        entries = audit_entries(session, action="amend")
    assert [e["target"] for e in entries] == [f"calibration run {first.id}"] * 2 + [
        f"calibration run {second.id}"
    ]


@pytest.mark.parametrize(
    ("changes", "reason"),
    [
        ({}, "why"),
        ({"temperature_c": float("nan")}, "why"),
        ({"temperature_c": -300.0}, "why"),
        ({"operator_note": "first"}, "why"),  # unchanged
        ({"colour": "red"}, "why"),
        ({"operator": "x"}, "  "),
    ],
)
def test_amend_refusals_change_nothing(tmp_path, make_calibration, changes, reason):
    engine = open_history(tmp_path / "h.sqlite")
    first, _ = _two_runs(engine, make_calibration)
    with pytest.raises(InputError):
        amend_run(engine, first.id, changes, reason=reason, by="ada")
    record, amendments = show_amended(engine, first.id)
    assert amendments == () and record.temperature_c == 20.1
    with pytest.raises(InputError, match="no calibration run"):
        amend_run(engine, 99, {"operator": "x"}, reason="r", by="ada")


@pytest.mark.parametrize("table", ["amendments", "audit_log"])
def test_append_only_tables_refuse_update_and_delete(history_url, make_calibration, table):
    engine = open_history(history_url)
    first, _ = _two_runs(engine, make_calibration)
    amend_run(engine, first.id, {"operator": "x"}, reason="r", by="ada")
    for statement in (f"UPDATE {table} SET id = id + 100", f"DELETE FROM {table}"):
        with pytest.raises((DBAPIError, InputError), match="append-only"), engine.begin() as c:
            c.execute(text(statement))
    with engine.connect() as c:
        # the audit log: the two runs recorded and the amendment
        rows = {"amendments": 1, "audit_log": 3}[table]
        assert c.execute(text(f"SELECT count(*) FROM {table}")).scalar() == rows
