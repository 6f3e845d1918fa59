"""Tables of the calibration history (the current schema; migrations/ builds it).

One row per machine; per machine its calibration runs (the result document of a calibrate
command as it was written, with the fields a laboratory filters on pulled out into
columns), the run's parameters one row each (``run_parameters``: the trend of one
parameter is one indexed query), task results and verification results.

``content_sha256`` (schema version 2) is unique per table through the index
``uq_<table>_content_sha256``: the same result is not recorded twice.

``parameter_vector`` (schema version 3) repeats a run's values as one array (little-endian
float64 bytes) in the order of ``run_parameters.position``: the long-term covariance reads
one row per run and decodes all of them at once.

Dates (schema version 4) are instants: :class:`UtcDateTime` stores them in UTC on every
backend (SQLite has no time zone type: before version 4 the offset of a date given with
one was dropped there, so SQLite and PostgreSQL disagreed), and
``performed_at_offset_min`` keeps the offset the date was given in (minutes east of UTC;
NULL for runs recorded before version 4). ``duplicate_results`` keeps the results that a
schema-1 database held twice and the upgrade to version 2 set aside (the first kept).

Values in ``run_parameters`` are in the parameter's customary unit (µm, µrad, µm/m), the
unit stored beside them, exactly as the result document states them.
"""

from __future__ import annotations

from datetime import UTC, datetime

from sqlalchemy import JSON, DateTime, Float, ForeignKey, Index, Integer, LargeBinary, String, Text
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column
from sqlalchemy.types import TypeDecorator

__all__ = [
    "RUNS",
    "AmendmentRow",
    "Base",
    "CalibrationRun",
    "DuplicateResult",
    "Machine",
    "RunParameter",
    "TaskResult",
    "UtcDateTime",
    "VerificationResult",
]


class UtcDateTime(TypeDecorator):
    """A time-zone-aware instant stored in UTC on every backend.

    Bound: an aware datetime converted to UTC (a naive one is a programming error: the
    caller states the zone). Read: an aware datetime in UTC (SQLite gives back the naive
    UTC text written; PostgreSQL's ``timestamptz`` an instant in the session's zone).
    """

    impl = DateTime(timezone=True)
    cache_ok = True

    def process_bind_param(self, value, dialect):
        if value is None:
            return None
        if value.tzinfo is None:
            raise TypeError(f"{value!r}: a naive datetime has no instant (state its zone)")
        return value.astimezone(UTC)

    def process_result_value(self, value, dialect):
        if value is None:
            return None
        return value.replace(tzinfo=UTC) if value.tzinfo is None else value.astimezone(UTC)


class Base(DeclarativeBase):
    """Declarative base of the history tables."""


class Machine(Base):
    """A machine tool or CMM: its definition's name, topology, error model and serial."""

    __tablename__ = "machines"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(200), unique=True)
    topology: Mapped[str | None] = mapped_column(String(200))
    model: Mapped[str | None] = mapped_column(String(200))
    serial: Mapped[str | None] = mapped_column(String(200))


class CalibrationRun(Base):
    """One calibration: the result document and the fields filtered on."""

    __tablename__ = "calibration_runs"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    machine_id: Mapped[int] = mapped_column(ForeignKey("machines.id"), index=True)
    kind: Mapped[str] = mapped_column(String(100))
    performed_at: Mapped[datetime] = mapped_column(UtcDateTime, index=True)
    performed_at_offset_min: Mapped[int | None] = mapped_column(Integer)
    recorded_at: Mapped[datetime] = mapped_column(UtcDateTime)
    software_version: Mapped[str] = mapped_column(String(100))
    operator_note: Mapped[str | None] = mapped_column(Text)
    artefact: Mapped[str | None] = mapped_column(String(500))
    temperature_c: Mapped[float | None] = mapped_column(Float)
    residual_statistics: Mapped[dict] = mapped_column(JSON)
    input_hashes: Mapped[dict] = mapped_column(JSON)
    result: Mapped[dict] = mapped_column(JSON)
    content_sha256: Mapped[str] = mapped_column(String(64))
    parameter_vector: Mapped[bytes | None] = mapped_column(LargeBinary)


class RunParameter(Base):
    """One parameter of a run: value and standard uncertainty in its customary unit."""

    __tablename__ = "run_parameters"
    run_id: Mapped[int] = mapped_column(
        ForeignKey("calibration_runs.id", ondelete="CASCADE"), primary_key=True
    )
    position: Mapped[int] = mapped_column(Integer, primary_key=True)
    name: Mapped[str] = mapped_column(String(50))
    unit: Mapped[str] = mapped_column(String(20))
    value: Mapped[float] = mapped_column(Float)
    u: Mapped[float | None] = mapped_column(Float)

    __table_args__ = (Index("ix_run_parameters_name_run", "name", "run_id"),)


class _Document:
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    kind: Mapped[str] = mapped_column(String(100))
    performed_at: Mapped[datetime] = mapped_column(UtcDateTime)
    performed_at_offset_min: Mapped[int | None] = mapped_column(Integer)
    recorded_at: Mapped[datetime] = mapped_column(UtcDateTime)
    software_version: Mapped[str] = mapped_column(String(100))
    operator_note: Mapped[str | None] = mapped_column(Text)
    input_hashes: Mapped[dict] = mapped_column(JSON)
    result: Mapped[dict] = mapped_column(JSON)
    content_sha256: Mapped[str] = mapped_column(String(64))


class TaskResult(_Document, Base):
    """A task-uncertainty result (``uncertainty-result``) of a machine."""

    __tablename__ = "task_results"
    machine_id: Mapped[int] = mapped_column(ForeignKey("machines.id"), index=True)


class VerificationResult(_Document, Base):
    """A verification result (``length-check``, ``conformity-decision``) of a machine."""

    __tablename__ = "verification_results"
    machine_id: Mapped[int] = mapped_column(ForeignKey("machines.id"), index=True)


class DuplicateResult(Base):
    """A result a schema-1 database held twice, set aside by the upgrade to version 2:
    the category, the run kept (the first), the duplicate's own fields and document."""

    __tablename__ = "duplicate_results"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    category: Mapped[str] = mapped_column(String(20))
    kept_id: Mapped[int] = mapped_column(Integer)
    duplicate_id: Mapped[int] = mapped_column(Integer)
    content_sha256: Mapped[str] = mapped_column(String(64))
    performed_at: Mapped[datetime | None] = mapped_column(UtcDateTime)
    recorded_at: Mapped[datetime | None] = mapped_column(UtcDateTime)
    operator_note: Mapped[str | None] = mapped_column(Text)
    result: Mapped[dict] = mapped_column(JSON)
    set_aside_at: Mapped[datetime] = mapped_column(UtcDateTime)


class AmendmentRow(Base):
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


#: The table of each category of result.
RUNS = {"calibration": CalibrationRun, "task": TaskResult, "verification": VerificationResult}
