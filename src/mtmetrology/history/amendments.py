"""Audited amendments of a recorded run's metadata (issue 32): a correction, never a
silent edit.

A run's date (``performed_at``), operator note, workshop temperature and operator can be
corrected after it was recorded: a run added without ``--date`` keeps the moment it was
recorded, and re-adding it with the right date is refused as a duplicate (the result
document is the same). :func:`amend_run` changes the run's columns (so that the trend, the
drift model and the order of the runs use the corrected value) and, in the same
transaction, appends one ``amendments`` row per changed field holding the value before and
after, who amended, when and why, and one row of the audit log. The ``amendments`` table is
append-only like the audit log (a trigger refuses UPDATE and DELETE, schema revision 0005):
the original value is always the ``old_value`` of the field's first amendment.

The run records no operator column; the operator is a field of its amendments only (the
current operator is the last amended value, none before).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from datetime import UTC, datetime

from mtmetrology.errors import InputError
from mtmetrology.history.records import (
    TABLES,
    TEMPERATURE_RANGE_C,
    RunRecord,
    offset_minutes,
    run_record,
)
from mtmetrology.history.sql import connect, instant

__all__ = ["FIELDS", "Amendment", "amend_run", "run_amendments", "show_amended"]

#: Amendable fields -> the run column they change (None: kept in the amendments only).
FIELDS = {
    "performed_at": "performed_at",
    "operator_note": "operator_note",
    "temperature_c": "temperature_c",
    "operator": None,
}


@dataclass(frozen=True)
class Amendment:
    """One amended field: the value before and after (JSON forms: ISO 8601 dates)."""

    id: int
    category: str
    run_id: int
    field: str
    old_value: object
    new_value: object
    reason: str
    amended_by: str
    amended_at: datetime

    def to_dict(self) -> dict:
        """JSON form."""
        return {
            "id": self.id,
            "category": self.category,
            "run_id": self.run_id,
            "field": self.field,
            "old_value": self.old_value,
            "new_value": self.new_value,
            "reason": self.reason,
            "amended_by": self.amended_by,
            "amended_at": self.amended_at.isoformat(),
        }


def _json_value(value):
    return value.isoformat() if isinstance(value, datetime) else value


def _utc(moment: datetime) -> datetime:
    """``moment`` as UTC (naive: taken as UTC); stored in UTC on every backend."""
    if moment.tzinfo is None:
        return moment.replace(tzinfo=UTC)
    return moment.astimezone(UTC)


def _checked(changes: dict) -> dict:
    unknown = sorted(set(changes) - set(FIELDS))
    if unknown:
        raise InputError(f"amendment: {unknown[0]}: not an amendable field ({', '.join(FIELDS)})")
    out = {k: v for k, v in changes.items() if v is not None}
    if not out:
        raise InputError("amendment: nothing to amend (give a date, note, temperature or operator)")
    if "performed_at" in out:
        if not isinstance(out["performed_at"], datetime):
            raise InputError("amendment: date: must be a date and time")
        out["performed_at"] = _utc(out["performed_at"])
    if "temperature_c" in out:
        t = out["temperature_c"]
        lo, hi = TEMPERATURE_RANGE_C
        if not (isinstance(t, int | float) and math.isfinite(t) and lo <= t <= hi):
            raise InputError(f"amendment: temperature {t!r} °C: not within {lo:g} … {hi:g} °C")
        out["temperature_c"] = float(t)
    for key in ("operator_note", "operator"):
        if key in out and not isinstance(out[key], str):
            raise InputError(f"amendment: {key}: must be text")
    return out


def amend_run(
    engine,
    run_id: int,
    changes: dict,
    *,
    reason: str,
    by: str,
    category: str = "calibration",
) -> tuple[Amendment, ...]:
    """Amend a run's metadata, keeping the original (one transaction).

    Parameters
    ----------
    engine : Engine
        The history (:func:`~mtmetrology.history.database.open_history`).
    run_id : int
        The run's number in its category.
    changes : dict
        New values of any of :data:`FIELDS` (None: unchanged): ``performed_at`` (datetime,
        UTC when naive), ``operator_note``, ``temperature_c`` (°C, within −50 … 100),
        ``operator``.
    reason : str
        Why (required, not blank).
    by : str
        Who amends (a user name; the command line records ``cli:NAME``).
    category : {"calibration", "task", "verification"}

    Returns
    -------
    tuple of Amendment
        One per field whose value changed (a field given its current value is not an
        amendment and is left out).

    Raises
    ------
    InputError
        No such run, an unknown field, an implausible value, a blank reason, a temperature
        on a run without one (task and verification results), or nothing that changes.
    """
    from sqlalchemy import text
    from sqlalchemy.orm import Session

    from mtmetrology.history import schema
    from mtmetrology.history.audit import audit
    from mtmetrology.history.database import writer

    if category not in TABLES:
        raise InputError(f"category {category!r}: not one of {', '.join(TABLES)}")
    if not isinstance(reason, str) or not reason.strip():
        raise InputError("amendment: --why: give the reason for the amendment")
    if not isinstance(by, str) or not by.strip():
        raise InputError("amendment: --by: name who amends")
    given = changes.get("performed_at")
    # the offset the new date was given in is kept beside the UTC instant, as on add
    # (schema 0004); a naive date is UTC
    offset_min = (
        offset_minutes(_utc(given) if given.tzinfo is None else given)
        if isinstance(given, datetime)
        else None
    )
    wanted = _checked(changes)
    table = schema.RUNS[category]
    if "temperature_c" in wanted and category != "calibration":
        raise InputError(f"amendment: a {category} run records no temperature")
    now = datetime.now(UTC)
    with Session(writer(engine)) as session, session.begin():
        if engine.dialect.name == "postgresql":
            session.execute(text("SELECT pg_advisory_xact_lock(24025)"))  # writers queue
        run = session.get(table, run_id)
        if run is None:
            raise InputError(f"run {run_id}: no {category} run of that number in the history")
        current = _current(session, run, category)
        rows = []
        for name, new in wanted.items():
            old = current[name]
            if _json_value(old) == _json_value(new):
                continue
            if FIELDS[name] is not None:
                setattr(run, FIELDS[name], new)
            if name == "performed_at":
                run.performed_at_offset_min = offset_min
            rows.append(
                schema.AmendmentRow(
                    category=category,
                    run_id=run_id,
                    field=name,
                    old_value=_json_value(old),
                    new_value=_json_value(new),
                    reason=reason.strip(),
                    amended_by=by,
                    amended_at=now,
                )
            )
        if not rows:
            raise InputError(f"run {run_id}: the values given are the recorded ones")
        session.add_all(rows)
        audit(
            session,
            by,
            "amend",
            f"{category} run {run_id}",
            {"fields": {r.field: [r.old_value, r.new_value] for r in rows}, "reason": reason},
        )
        session.flush()
        return tuple(_amendment(r) for r in rows)


def _current(session, run, category: str) -> dict:
    from sqlalchemy import select

    from mtmetrology.history.schema import AmendmentRow

    operator = session.scalar(
        select(AmendmentRow.new_value)
        .where(
            AmendmentRow.category == category,
            AmendmentRow.run_id == run.id,
            AmendmentRow.field == "operator",
        )
        .order_by(AmendmentRow.id.desc())
        .limit(1)
    )
    return {
        "performed_at": _utc(run.performed_at),
        "operator_note": run.operator_note,
        "temperature_c": getattr(run, "temperature_c", None),
        "operator": operator,
    }


def _amendment(row) -> Amendment:
    """An :class:`Amendment` of a row of the ORM (:func:`amend_run`)."""
    return Amendment(
        id=row.id,
        category=row.category,
        run_id=row.run_id,
        field=row.field,
        old_value=row.old_value,
        new_value=row.new_value,
        reason=row.reason,
        amended_by=row.amended_by,
        amended_at=_utc(row.amended_at),
    )


#: A run's amendments, oldest first.
_AMENDMENTS = (
    "SELECT id, category, run_id, field, old_value, new_value, reason, amended_by, amended_at "
    "FROM amendments WHERE category = :category AND run_id = :run ORDER BY id"
)


def amendments_of(c, run_id: int, category: str = "calibration") -> tuple[Amendment, ...]:
    """A run's amendments, oldest first, read on an open connection
    (:func:`mtmetrology.history.sql.connect`)."""
    return tuple(
        Amendment(
            id=r[0],
            category=r[1],
            run_id=r[2],
            field=r[3],
            old_value=c.json(r[4]),
            new_value=c.json(r[5]),
            reason=r[6],
            amended_by=r[7],
            amended_at=instant(r[8]),
        )
        for r in c.rows(_AMENDMENTS, category=category, run=run_id)
    )


def run_amendments(engine, run_id: int, category: str = "calibration") -> tuple[Amendment, ...]:
    """A run's amendments, oldest first (``engine``: an engine or the database, as
    :func:`~mtmetrology.history.records.show_run` takes it)."""
    with connect(engine, read_only=True) as history, history.transaction() as c:
        return amendments_of(c, run_id, category)


def show_amended(
    engine, run_id: int, category: str = "calibration"
) -> tuple[RunRecord, tuple[Amendment, ...]]:
    """A run as it stands (:func:`~mtmetrology.history.records.show_run`) and its
    amendments, oldest first, in one read transaction (what ``mtm history show`` and the
    web application show; ``engine``: an engine or the database, opened as a reader)."""
    if category not in TABLES:
        raise InputError(f"category {category!r}: not one of {', '.join(TABLES)}")
    with connect(engine, read_only=True) as history, history.transaction() as c:
        return run_record(c, run_id, category), amendments_of(c, run_id, category)


def original_values(amendments: tuple[Amendment, ...]) -> dict:
    """Each amended field's value as first recorded (the first amendment's old value)."""
    out: dict = {}
    for a in amendments:
        out.setdefault(a.field, a.old_value)
    return out
