"""Where the calibration history lives, opening it, and the one rule for its faults.

The database is a SQLite file by default, in the user's data directory
(``$XDG_DATA_HOME/mtmetrology/history.sqlite`` on Linux, the platform's equivalent
elsewhere, from :mod:`platformdirs`); the environment variable ``MTMETROLOGY_DB`` or the
``--db`` option names another file or a database URL (``postgresql://user@host/db`` for a
laboratory's server).

Opening (:func:`open_history`) reads the schema revision with one ``SELECT`` of
``alembic_version``. At the current revision nothing more happens (Alembic is not even
imported). A writer (the default) brings an older database to the current schema with the
Alembic migrations shipped in ``mtmetrology/history/migrations``; a reader
(``read_only=True``) never migrates and never takes the write lock: it refuses an older
database with the command that upgrades it (``mtm history upgrade``), and reads a SQLite
file on a read-only file system as immutable. An empty database (a new file) is given the
schema by either.

Writes are transactions: a run is recorded with its parameters in one ``COMMIT``, so a
process killed in the middle leaves the run absent. On SQLite every write transaction
starts with ``BEGIN IMMEDIATE`` (it takes the write lock at once and waits up to the busy
timeout for another writer, instead of failing on a read-to-write upgrade); reads begin
with a plain ``BEGIN`` and, in WAL mode, never wait for a writer.

The constants and functions that need no SQLAlchemy (:data:`HEAD`, :func:`database_url`,
:func:`database_fault`...) live in :mod:`mtmetrology.history.opening` and are imported
from there: the short commands (``list``, ``show``, ``add``) read a SQLite file at the
current revision without SQLAlchemy (:mod:`mtmetrology.history.sql`).

Faults (:func:`database_fault`, attached to every engine): whatever the database driver
raises becomes one line naming the database and the fault, never "a bug":

- the machine refuses the operation (disk full, read-only file or directory, permissions,
  I/O error, a lock held past the busy timeout, a server that does not answer):
  :class:`~mtmetrology.errors.EnvironmentFailure`, exit 3;
- the database itself cannot be used (not a database, a corrupted or truncated file,
  tables of another application, a schema revision this version does not know or an
  older one on a read, a violated constraint): :class:`~mtmetrology.errors.InputError`,
  exit 2.

Nothing is written before the fault is found: a file that is not a history is refused
before any table is created in it.
"""

from __future__ import annotations

import os
import warnings
from contextlib import nullcontext
from pathlib import Path
from typing import TYPE_CHECKING

from sqlalchemy import create_engine, event
from sqlalchemy.engine import make_url
from sqlalchemy.exc import ArgumentError, IntegrityError
from sqlalchemy.pool import NullPool, QueuePool

from mtmetrology.errors import EnvironmentFailure, InputError
from mtmetrology.history.opening import (
    BUSY_TIMEOUT_S,
    DB_ENV,
    HEAD,
    REVISIONS,
    canonical_sha256,
    database_fault,
    database_url,
    default_location,
    read_only_medium,
    sqlite_configure,
    sqlite_open,
)

if TYPE_CHECKING:
    from sqlalchemy import Engine

__all__ = [
    "DB_ENV",
    "HEAD",
    "REVISIONS",
    "HistoryUpgradeWarning",
    "canonical_sha256",
    "database_fault",
    "database_url",
    "default_location",
    "migrate",
    "open_history",
    "schema_revision",
    "writer",
]

_MIGRATIONS = Path(__file__).with_name("migrations")
#: A server's pooled connections kept open, and opened beyond them at a peak (together the
#: 40 threads anyio runs a server's synchronous endpoints in: none waits for a connection).
_POOL_SIZE = 10
_POOL_OVERFLOW = 30
#: The tables of the history (any revision): a database holding other tables and not
#: these is another application's and is refused.
_OURS = frozenset(
    {
        "alembic_version",
        "machines",
        "calibration_runs",
        "run_parameters",
        "task_results",
        "verification_results",
        "duplicate_results",
        "amendments",
        "audit_log",
        "users",
        "api_tokens",
        "machine_limits",
        "lab_settings",
    }
)


class HistoryUpgradeWarning(UserWarning):
    """A migration changed data to reach the current schema (say what, once)."""


def shown_name(url) -> str:
    """The database as a person names it: the file of a SQLite URL, else the URL without
    its password."""
    parsed = make_url(url) if isinstance(url, str) else url
    if parsed.get_backend_name() == "sqlite" and parsed.database:
        return parsed.database
    return parsed.render_as_string(hide_password=True)


def _engine(url: str, read_only: bool = False, pooled: bool = False) -> Engine:
    try:
        parsed = make_url(url)
    except ArgumentError:
        raise InputError(f"database URL {url!r} is not a URL (dialect://user@host/name)") from None
    shown = shown_name(parsed)
    path = None
    if parsed.get_backend_name() == "sqlite":
        path = parsed.database
        if path == ":memory:":
            path = None
        if path:
            try:
                Path(path).parent.mkdir(parents=True, exist_ok=True)
            except OSError as err:
                raise EnvironmentFailure(f"database {shown}: {err.strerror or err}") from None
            if Path(path).is_dir():
                raise InputError(f"database {shown}: a directory, not a SQLite file")
        # A reader of a file on a read-only file system: WAL mode needs its -shm file,
        # which cannot be made there; no writer can exist, so the file is immutable.
        frozen = read_only and bool(path) and read_only_medium(path)
        options = {}
        if frozen:
            options["creator"] = lambda: sqlite_open(path, frozen=True)
        engine = create_engine(
            parsed,
            connect_args={"timeout": BUSY_TIMEOUT_S},
            **_pool(pooled),
            **options,
        )

        @event.listens_for(engine, "connect")
        def _connect(dbapi_connection, _record):
            try:  # the configuration of the sqlite3 driver of mtmetrology.history.sql
                sqlite_configure(dbapi_connection, frozen)
            except Exception as err:  # sqlite3.Error: raised outside SQLAlchemy's wrapping
                raise database_fault(shown, err, path) from None

        @event.listens_for(engine, "begin")
        def _begin(connection):
            write = connection.get_execution_options().get("history_write", False)
            connection.exec_driver_sql("BEGIN IMMEDIATE" if write else "BEGIN")

    elif parsed.get_backend_name() == "postgresql":
        if parsed.drivername == "postgresql":
            parsed = parsed.set(drivername="postgresql+psycopg")
        try:
            engine = create_engine(parsed, connect_args={"connect_timeout": 10}, **_pool(pooled))
        except ModuleNotFoundError as err:
            raise EnvironmentFailure(
                f"database {shown}: the driver {err.name} is not installed "
                "(pip install 'psycopg[binary]')"
            ) from None
    else:
        raise InputError(
            f"database URL {url!r}: {parsed.get_backend_name()} is not supported "
            "(a SQLite file or postgresql://...)"
        )

    @event.listens_for(engine, "handle_error")
    def _fault(context):
        # the duplicate check of add_result reads IntegrityError itself
        if isinstance(context.sqlalchemy_exception, IntegrityError):
            return
        raise database_fault(shown, context.original_exception, path) from None

    return engine


def _pool(pooled: bool) -> dict:
    """The engine's connection pool: none for a command (one process, a few statements, no
    file handle left open behind it), a bounded pool for a server, where opening a
    connection per request cost more than the request's queries (0.38 ms of a SQLite
    connection with its pragmas against 0.13 ms for the history's version query; a
    PostgreSQL connection is a TCP and authentication round trip)."""
    if not pooled:
        return {"poolclass": NullPool}
    return {"poolclass": QueuePool, "pool_size": _POOL_SIZE, "max_overflow": _POOL_OVERFLOW}


def writer(engine: Engine) -> Engine:
    """``engine`` for a write transaction (on SQLite it begins with ``BEGIN IMMEDIATE``;
    reads begin with a plain ``BEGIN`` and never wait for a writer in WAL mode)."""
    return engine.execution_options(history_write=True)


def _tables(connection) -> set[str]:
    if connection.dialect.name == "sqlite":
        query = "SELECT name FROM sqlite_master WHERE type = 'table'"
    else:
        query = (
            "SELECT table_name FROM information_schema.tables WHERE table_schema = current_schema()"
        )
    return {row[0] for row in connection.exec_driver_sql(query)}


def schema_revision(engine: Engine) -> str | None:
    """The revision the database is at: one ``SELECT`` of ``alembic_version`` (None for
    an empty database).

    Raises
    ------
    InputError
        The database holds tables but no ``alembic_version``: another application's.
    """
    postgresql = engine.dialect.name == "postgresql"
    with engine.connect() as connection:
        try:
            # a savepoint: PostgreSQL aborts the transaction on a missing table
            with connection.begin_nested() if postgresql else nullcontext():
                query = "SELECT version_num FROM alembic_version"
                return connection.exec_driver_sql(query).scalar()
        except InputError:
            pass  # no such table: an empty database or another application's
        tables = _tables(connection)
    foreign = sorted(tables - _OURS)
    if foreign or tables:
        shown = shown_name(engine.url)
        listed = ", ".join(foreign[:5] or sorted(tables)[:5])
        raise InputError(
            f"database {shown}: not a calibration history (it holds other tables: {listed}); "
            "give a new file or an empty database"
        )
    return None


def migrate(engine: Engine, revision: str = HEAD) -> None:
    """Upgrade the database to ``revision`` (default: the current schema) with Alembic,
    under the write lock. Warns (:class:`HistoryUpgradeWarning`) when the upgrade set
    duplicate results aside (revision 0002)."""
    from alembic import command
    from alembic.config import Config

    config = Config()
    config.set_main_option("script_location", str(_MIGRATIONS))
    with writer(engine).connect() as connection:
        config.attributes["connection"] = connection
        config.attributes["notices"] = notices = []
        command.upgrade(config, revision)
    for notice in notices:
        warnings.warn(f"database {shown_name(engine.url)}: {notice}", HistoryUpgradeWarning, 2)


def open_history(
    db: str | os.PathLike | None = None,
    *,
    revision: str = HEAD,
    read_only: bool = False,
    pooled: bool = False,
) -> Engine:
    """The history database as an engine at ``revision``.

    Parameters
    ----------
    db : str or path, optional
        A SQLite file or a URL (:func:`database_url`).
    revision : str
        The schema wanted (tests make older databases with it).
    read_only : bool
        A reader: never migrates and never takes the write lock; a database at an older
        revision is refused with the command that upgrades it; a file on a read-only file
        system is read as immutable. A writer (default) migrates an older database.
    pooled : bool
        Keep up to ``_POOL_SIZE`` connections open for reuse (a server, ``mtm serve``);
        by default each connection is opened and closed with its use (a command).

    Raises
    ------
    InputError
        The URL is not one or names an unsupported database; the database is not a
        history, is corrupted, or is at a revision this version does not know (or an older
        one, for a reader).
    EnvironmentFailure
        The disk, the file system or the server refuses (full, read-only, unreachable).
    """
    url = database_url(db)
    engine = _engine(url, read_only, pooled)
    current = schema_revision(engine)
    if current == revision:
        return engine
    shown = shown_name(url)
    if current is not None and current not in REVISIONS:
        raise EnvironmentFailure(
            f"database {shown}: schema revision {current!r} is newer than this mtmetrology "
            f"knows (up to {HEAD}); upgrade mtmetrology"
        )
    if read_only and current is not None:
        raise InputError(
            f"database {shown}: schema revision {current}, this mtmetrology reads {revision}; "
            f"upgrade it first: mtm history upgrade --db {shown}"
        )
    migrate(engine, revision)
    return engine
