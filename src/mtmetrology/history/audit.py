"""The audit trail of the calibration history: who changed what, when (append-only).

Every change to the history made through the web application or an amendment from the
command line writes one row of ``audit_log``: the actor (a user name, or ``cli:NAME``),
the time (UTC), the action (``upload``, ``amend``, ``user-create`` ...), its target
(``calibration run 3``, ``user ada``) and a JSON detail. The table is append-only in the
database itself (schema revision 0005): a trigger on SQLite and on PostgreSQL refuses every
``UPDATE`` and ``DELETE`` of its rows (and PostgreSQL a ``TRUNCATE``), so that no program
talking to the database, this one included, can rewrite the record.

The users and API tokens of the web application live beside it (``users``, ``api_tokens``):
passwords as argon2id hashes, tokens as the SHA-256 of a 256-bit random secret.
"""

from __future__ import annotations

from datetime import UTC, datetime

from sqlalchemy import (
    JSON,
    Boolean,
    DateTime,
    ForeignKey,
    Integer,
    String,
    select,
)
from sqlalchemy.orm import Mapped, Session, mapped_column

from mtmetrology.history.schema import Base
from mtmetrology.history.sql import Alchemy, write_audit

__all__ = ["ROLES", "ApiToken", "AuditEntry", "User", "audit", "audit_entries"]

#: Roles of the web application, each allowed what the ones before it may do.
ROLES = ("viewer", "engineer", "admin")


class AuditEntry(Base):
    """One row of the append-only audit log."""

    __tablename__ = "audit_log"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    at: Mapped[datetime] = mapped_column(DateTime(timezone=True), index=True)
    actor: Mapped[str] = mapped_column(String(200))
    action: Mapped[str] = mapped_column(String(50), index=True)
    target: Mapped[str] = mapped_column(String(300))
    detail: Mapped[dict] = mapped_column(JSON)


class User(Base):
    """A user of the web application (argon2id password hash, one role of :data:`ROLES`)."""

    __tablename__ = "users"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    username: Mapped[str] = mapped_column(String(100), unique=True)
    password_hash: Mapped[str] = mapped_column(String(200))
    role: Mapped[str] = mapped_column(String(20))
    active: Mapped[bool] = mapped_column(Boolean)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True))


class ApiToken(Base):
    """An API token: the SHA-256 of its secret (the secret is shown once), revocable."""

    __tablename__ = "api_tokens"
    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    user_id: Mapped[int] = mapped_column(ForeignKey("users.id"), index=True)
    name: Mapped[str] = mapped_column(String(100))
    token_sha256: Mapped[str] = mapped_column(String(64), unique=True)
    created_at: Mapped[datetime] = mapped_column(DateTime(timezone=True))
    revoked_at: Mapped[datetime | None] = mapped_column(DateTime(timezone=True))


def audit(
    session: Session, actor: str, action: str, target: str, detail: dict | None = None
) -> int:
    """Add one audit row in ``session``'s transaction (committed with the change it
    records); its id. The row is written by the one writer of the log,
    :func:`mtmetrology.history.sql.write_audit`, on the session's connection (the short
    commands write it through :mod:`sqlite3` with the same statement)."""
    return write_audit(Alchemy(session.connection()), actor, action, target, detail)


def audit_entries(
    session: Session, *, limit: int = 200, action: str | None = None, target: str | None = None
) -> list[dict]:
    """The latest audit rows, newest first, as JSON-ready mappings."""
    query = select(AuditEntry).order_by(AuditEntry.id.desc()).limit(limit)
    if action is not None:
        query = query.where(AuditEntry.action == action)
    if target is not None:
        query = query.where(AuditEntry.target == target)
    return [
        {
            "id": e.id,
            "at": _utc(e.at).isoformat(),
            "actor": e.actor,
            "action": e.action,
            "target": e.target,
            "detail": e.detail,
        }
        for e in session.scalars(query)
    ]


def _utc(moment: datetime) -> datetime:
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=UTC)
