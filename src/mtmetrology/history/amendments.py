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

from sqlalchemy import JSON, DateTime, Integer, String, Text, select, text
from sqlalchemy.orm import Mapped, Session, mapped_column

from mtmetrology.errors import InputError
from mtmetrology.history import schema
from mtmetrology.history.audit import audit
from mtmetrology.history.database import writer
from mtmetrology.history.records import TEMPERATURE_RANGE_C, RunRecord, offset_minutes, show_run

__all__ = ["FIELDS", "Amendment", "AmendmentRow", "amend_run", "run_amendments", "show_amended"]

#: Amendable fields -> the run column they change (None: kept in the amendments only).
FIELDS = {
    "performed_at": "performed_at",
    "operator_note": "operator_note",
    "temperature_c": "temperature_c",
    "operator": None,
}
_TABLES = {
    "calibration": schema.CalibrationRun,
    "task": schema.TaskResult,
    "verification": schema.VerificationResult,
}


class AmendmentRow(schema.Base):
    """One amended field of one run (append-only)."""

    __tablename__ = "amendments"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    category: Mapped[str] = mapped_column(String(20))
    run_id: Mapped[int] = mapped_column(Integer, index=True)
    field: Mapped[str] = mapped_column(String(50))
    old_value: Mapped[object] = mapped_column(JSON)
    new_value: Mapped[object] = mapped_column(JSON)
    reason: Mapped[str] = mapped_column(Text)
    amended_by: Mapped[str] = mapped_column(String(200))
    amended_at: Mapped[datetime] = mapped_column(DateTime(timezone=True))


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
    if category not in _TABLES:
        raise InputError(f"category {category!r}: not one of {', '.join(_TABLES)}")
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
    table = _TABLES[category]
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
                AmendmentRow(
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


def _current(session: Session, run, category: str) -> dict:
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


def _amendment(row: AmendmentRow) -> Amendment:
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


def run_amendments(engine, run_id: int, category: str = "calibration") -> tuple[Amendment, ...]:
    """A run's amendments, oldest first."""
    with Session(engine) as session:
        rows = session.scalars(
            select(AmendmentRow)
            .where(AmendmentRow.category == category, AmendmentRow.run_id == run_id)
            .order_by(AmendmentRow.id)
        )
        return tuple(_amendment(r) for r in rows)


def show_amended(
    engine, run_id: int, category: str = "calibration"
) -> tuple[RunRecord, tuple[Amendment, ...]]:
    """A run as it stands (:func:`~mtmetrology.history.records.show_run`) and its
    amendments, oldest first (what ``mtm history show`` and the web application show)."""
    return show_run(engine, run_id, category), run_amendments(engine, run_id, category)


def original_values(amendments: tuple[Amendment, ...]) -> dict:
    """Each amended field's value as first recorded (the first amendment's old value)."""
    out: dict = {}
    for a in amendments:
        out.setdefault(a.field, a.old_value)
    return out
