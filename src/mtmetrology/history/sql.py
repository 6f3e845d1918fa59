"""One SQL text per operation, two drivers: the history's records without SQLAlchemy.

``mtm history list``, ``show`` and ``add`` are short processes; importing SQLAlchemy alone
costs about twice the start-up of ``python -c "import numpy"`` (issue 32). The operations
they run (:func:`~mtmetrology.history.records.list_runs`,
:func:`~mtmetrology.history.records.show_run`,
:func:`~mtmetrology.history.records.add_results` and the amendments shown beside a run)
are therefore written once, as SQL text with named parameters (``:name``), and run by
either driver:

- a SQLite file at the current schema revision: the standard library's :mod:`sqlite3`,
  configured as :func:`mtmetrology.history.database.open_history` configures SQLAlchemy's
  engine (busy timeout, ``PRAGMA foreign_keys = ON``, WAL journal, ``BEGIN IMMEDIATE``
  for a write and a plain ``BEGIN`` for a read, a file on a read-only file system opened
  immutable by a reader) and its faults mapped by the same rule (:func:`database_fault`);
- anything else (a PostgreSQL URL, an existing SQLAlchemy ``Engine``, a SQLite file at
  another revision, a new file): SQLAlchemy's ``text()`` on the engine of
  :func:`~mtmetrology.history.database.open_history`, which migrates (a writer) or
  refuses (a reader) as it always did.

The revision is read with one ``SELECT version_num FROM alembic_version`` through
:mod:`sqlite3`; anything but the current revision (:data:`HEAD`), or any fault of that
first read, hands the database to SQLAlchemy, which reports or repairs it.

Values are encoded and decoded here only: instants are written to SQLite as the naive UTC
text SQLAlchemy writes (``YYYY-MM-DD HH:MM:SS.ffffff``, :class:`~mtmetrology.history
.schema.UtcDateTime`) and bound as ``UtcDateTime`` through SQLAlchemy; JSON as
``json.dumps`` text on SQLite (what SQLAlchemy's ``JSON`` writes) and as ``JSON`` through
SQLAlchemy. Read back, SQLite gives text and PostgreSQL gives aware datetimes and parsed
JSON; :func:`instant` accepts both, and each connection's ``json`` method decodes as its
driver needs.

What every opening needs without SQLAlchemy (:data:`HEAD`, :func:`database_url`, the
configuration of a SQLite connection, :func:`database_fault`) is in
:mod:`mtmetrology.history.opening`.
"""

from __future__ import annotations

import json
import os
import sqlite3
from collections.abc import Iterator
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from mtmetrology.history.opening import (
    HEAD,
    database_fault,
    database_url,
    read_only_medium,
    sqlite_configure,
    sqlite_open,
)

__all__ = ["Alchemy", "Conflict", "Json", "connect", "instant", "write_audit"]

#: SQLAlchemy's text form of a datetime on SQLite (naive; the history writes UTC).
_SQLITE_INSTANT = "%Y-%m-%d %H:%M:%S.%f"


class Json:
    """A parameter bound to a JSON column (a mapping, a list, a string or None)."""

    __slots__ = ("value",)

    def __init__(self, value: object):
        self.value = value


class Conflict(Exception):
    """A write refused by a constraint of the database (``original``: the driver's error);
    the caller says which result it was."""

    def __init__(self, original: BaseException):
        super().__init__(str(original))
        self.original = original


def instant(value: datetime | str | None) -> datetime | None:
    """A stored instant as an aware UTC datetime: SQLite's naive UTC text, or the
    driver's datetime (naive: UTC; aware: converted)."""
    if value is None:
        return None
    if isinstance(value, str):
        value = datetime.fromisoformat(value)
    return value.replace(tzinfo=UTC) if value.tzinfo is None else value.astimezone(UTC)


def _sqlite_value(value: object) -> object:
    if isinstance(value, Json):
        return json.dumps(value.value)
    if isinstance(value, datetime):
        if value.tzinfo is None:
            raise TypeError(f"{value!r}: a naive datetime has no instant (state its zone)")
        return value.astimezone(UTC).strftime(_SQLITE_INSTANT)
    return value


class _Decoding:
    """Decoding of a stored JSON value, the one place it happens: SQLite gives the text
    written, PostgreSQL's driver the value parsed (a JSON string is then a ``str`` too, so
    the driver, not the value's type, says which)."""

    dialect: str

    def json(self, value: object) -> object:
        """A stored JSON value (None for SQL NULL). SQLite's ``JSON`` columns have numeric
        affinity: a number written as JSON text comes back a number, any other value as
        its text."""
        if self.dialect == "sqlite" and isinstance(value, str):
            return json.loads(value)
        return value


class _Sqlite(_Decoding):
    """The :mod:`sqlite3` driver: one connection, transactions begun by :meth:`transaction`."""

    dialect = "sqlite"

    def __init__(self, raw: sqlite3.Connection, path: str):
        self.raw = raw
        self.shown = self.path = path

    def _run(self, sql: str, params: dict) -> sqlite3.Cursor:
        try:
            return self.raw.execute(sql, {k: _sqlite_value(v) for k, v in params.items()})
        except sqlite3.IntegrityError as err:
            raise Conflict(err) from None
        except sqlite3.Error as err:
            raise database_fault(self.shown, err, self.path) from None

    def rows(self, sql: str, **params) -> list[tuple]:
        """All rows of a query."""
        return self._run(sql, params).fetchall()

    def first(self, sql: str, **params) -> tuple | None:
        """The first row of a query, or None."""
        return self._run(sql, params).fetchone()

    def insert(self, sql: str, **params) -> int:
        """Run an ``INSERT`` of one row; its ``id``."""
        return self._run(sql, params).lastrowid

    def execute(self, sql: str, **params) -> None:
        """Run a statement (``UPDATE``...)."""
        self._run(sql, params)

    @contextmanager
    def transaction(self, write: bool = False) -> Iterator[_Sqlite]:
        """A transaction: ``BEGIN IMMEDIATE`` (the write lock at once, waiting up to the
        busy timeout for another writer) or ``BEGIN``; committed when the block ends,
        rolled back when it raises."""
        self._run("BEGIN IMMEDIATE" if write else "BEGIN", {})
        try:
            yield self
            self._run("COMMIT", {})
        except BaseException:
            if self.raw.in_transaction:  # a refusal, or a COMMIT the disk refused
                self.raw.rollback()
            raise


class Alchemy(_Decoding):
    """The SQLAlchemy driver: the same SQL text through ``text()`` on a connection
    (PostgreSQL, or any engine given; :mod:`mtmetrology.history.audit` wraps an ORM
    session's connection in it)."""

    def __init__(self, connection):
        from sqlalchemy import JSON, bindparam, text
        from sqlalchemy.exc import IntegrityError

        from mtmetrology.history.database import shown_name
        from mtmetrology.history.schema import UtcDateTime

        self.connection = connection
        self.dialect = connection.dialect.name
        self.shown = shown_name(connection.engine.url)
        self._text, self._bind, self._integrity = text, bindparam, IntegrityError
        self._types = {Json: JSON(), datetime: UtcDateTime()}

    def _run(self, sql: str, params: dict):
        statement = self._text(sql)
        typed = [self._bind(k, type_=self._types[type(v)]) for k, v in params.items() if _typed(v)]
        if typed:
            statement = statement.bindparams(*typed)
        values = {k: v.value if isinstance(v, Json) else v for k, v in params.items()}
        try:
            return self.connection.execute(statement, values)
        except self._integrity as err:
            raise Conflict(err.orig) from None

    def rows(self, sql: str, **params) -> list[tuple]:
        """All rows of a query."""
        return [tuple(r) for r in self._run(sql, params)]

    def first(self, sql: str, **params) -> tuple | None:
        """The first row of a query, or None."""
        row = self._run(sql, params).first()
        return None if row is None else tuple(row)

    def insert(self, sql: str, **params) -> int:
        """Run an ``INSERT`` of one row; its ``id`` (``RETURNING`` on PostgreSQL, whose
        driver has no last row id)."""
        if self.dialect == "postgresql":
            return self._run(f"{sql} RETURNING id", params).scalar_one()
        return self._run(sql, params).lastrowid

    def execute(self, sql: str, **params) -> None:
        """Run a statement (``UPDATE``...)."""
        self._run(sql, params)


def _typed(value: object) -> bool:
    return isinstance(value, Json | datetime)


class _Engine:
    """An SQLAlchemy engine whose transactions yield :class:`Alchemy` connections."""

    def __init__(self, engine):
        self.engine = engine
        self.dialect = engine.dialect.name

    @contextmanager
    def transaction(self, write: bool = False) -> Iterator[Alchemy]:
        """A transaction on a new connection (a writer's begins ``BEGIN IMMEDIATE`` on
        SQLite; on PostgreSQL writers queue on an advisory lock, as SQLite's do on the
        write lock: two first runs of a new machine would otherwise both insert it)."""
        from mtmetrology.history.database import writer

        with (writer(self.engine) if write else self.engine).begin() as connection:
            tx = Alchemy(connection)
            if write and self.dialect == "postgresql":
                tx.execute("SELECT pg_advisory_xact_lock(24025)")
            yield tx


def _sqlite_path(url: str) -> str | None:
    """The file of a plain SQLite URL (``sqlite:///PATH``, no query), else None."""
    prefix = "sqlite:///"
    if not url.startswith(prefix) or "?" in url or url[len(prefix) :] in ("", ":memory:"):
        return None
    return url[len(prefix) :]


def _at_head(path: str, read_only: bool) -> _Sqlite | None:
    """A :mod:`sqlite3` connection to an existing file at :data:`HEAD`, else None (a new
    file, another revision, or any fault: SQLAlchemy's opening names or mends it)."""
    if not Path(path).is_file():
        return None
    raw = None
    try:
        frozen = read_only and read_only_medium(path)
        raw = sqlite_open(path, frozen)
        sqlite_configure(raw, frozen)
        row = raw.execute("SELECT version_num FROM alembic_version").fetchone()
    except sqlite3.Error:
        row = None
    if row is not None and row[0] == HEAD:
        return _Sqlite(raw, path)
    if raw is not None:
        raw.close()
    return None


@contextmanager
def connect(db: Any = None, *, read_only: bool = False) -> Iterator[_Sqlite | _Engine]:
    """The history for :func:`records <mtmetrology.history.records.list_runs>`' SQL.

    Parameters
    ----------
    db : Engine, str, path or None
        An SQLAlchemy engine (used as it is), or a SQLite file or URL
        (:func:`database_url`: None is ``$MTMETROLOGY_DB`` or the default file).
    read_only : bool
        A reader (see :func:`mtmetrology.history.database.open_history`).

    Yields
    ------
    history : object
        With ``dialect`` and ``transaction(write=False)``, a context that yields a
        connection with ``rows``, ``first``, ``insert``, ``execute`` (SQL text, ``:name``
        parameters) and ``json`` (decoding): :mod:`sqlite3` for a SQLite file at
        :data:`HEAD`, SQLAlchemy otherwise.

    Raises
    ------
    InputError, EnvironmentFailure
        As :func:`~mtmetrology.history.database.open_history`.
    """
    if db is not None and not isinstance(db, str | os.PathLike):
        yield _Engine(db)
        return
    url = database_url(db)
    path = _sqlite_path(url)
    fast = None if path is None else _at_head(path, read_only)
    if fast is None:
        from mtmetrology.history.database import open_history

        yield _Engine(open_history(url, read_only=read_only))
        return
    try:
        yield fast
    finally:
        fast.raw.close()


#: The audit row (:class:`mtmetrology.history.audit.AuditEntry`), written by one statement.
_AUDIT = (
    "INSERT INTO audit_log (at, actor, action, target, detail) "
    "VALUES (:at, :actor, :action, :target, :detail)"
)


def write_audit(
    connection: _Sqlite | Alchemy, actor: str, action: str, target: str, detail: dict | None
) -> int:
    """Append one row to the audit log in ``connection``'s transaction (committed with the
    change it records); its id. The one writer of the log
    (:func:`mtmetrology.history.audit.audit` calls it on an ORM session's connection)."""
    return connection.insert(
        _AUDIT,
        at=datetime.now(UTC),
        actor=actor,
        action=action,
        target=target,
        detail=Json(detail or {}),
    )
