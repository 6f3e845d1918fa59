"""Where the calibration history lives, and opening it at the current schema version.

The database is a SQLite file by default, in the user's data directory
(``$XDG_DATA_HOME/mtmetrology/history.sqlite`` on Linux, the platform's equivalent
elsewhere, from :mod:`platformdirs`); the environment variable ``MTMETROLOGY_DB`` or the
``--db`` option names another file or a database URL (``postgresql://user@host/db`` for a
laboratory's server). :func:`open_history` brings the schema to the current version with
the Alembic migrations shipped in ``mtmetrology/history/migrations`` before anything is
read or written.

Writes are transactions: a run is recorded with its parameters in one ``COMMIT``, so a
process killed in the middle leaves the run absent. On SQLite every write transaction
starts with ``BEGIN IMMEDIATE`` (it takes the write lock at once and waits up to the busy
timeout for another writer, instead of failing on a read-to-write upgrade).
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import platformdirs
from alembic import command
from alembic.config import Config
from sqlalchemy import Engine, create_engine, event, inspect
from sqlalchemy.engine import make_url
from sqlalchemy.exc import ArgumentError, OperationalError
from sqlalchemy.pool import NullPool

from mtmetrology.errors import EnvironmentFailure, InputError

__all__ = [
    "DB_ENV",
    "HEAD",
    "canonical_sha256",
    "database_url",
    "default_location",
    "migrate",
    "open_history",
    "writer",
]

#: Environment variable naming the history database (a file or a URL).
DB_ENV = "MTMETROLOGY_DB"
#: The current schema revision.
HEAD = "0005"
_MIGRATIONS = Path(__file__).with_name("migrations")
_BUSY_TIMEOUT_S = 60.0


def canonical_sha256(document: dict) -> str:
    """SHA-256 of ``document`` as canonical JSON (sorted keys, no spaces, UTF-8)."""
    text = json.dumps(document, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(text.encode()).hexdigest()


def default_location() -> Path:
    """The default SQLite file, in the user's data directory."""
    return Path(platformdirs.user_data_dir("mtmetrology", appauthor=False)) / "history.sqlite"


def database_url(db: str | os.PathLike | None = None) -> str:
    """The URL of the history database: ``db``, else ``$MTMETROLOGY_DB``, else the default
    file. A plain path (no ``://``) is a SQLite file."""
    chosen = str(db) if db is not None else os.environ.get(DB_ENV) or str(default_location())
    if "://" in chosen:
        return chosen
    return f"sqlite:///{Path(chosen).expanduser().resolve()}"


def _engine(url: str) -> Engine:
    try:
        parsed = make_url(url)
    except ArgumentError:
        raise InputError(f"database URL {url!r} is not a URL (dialect://user@host/name)") from None
    if parsed.get_backend_name() == "sqlite":
        path = parsed.database
        if path and path != ":memory:":
            Path(path).parent.mkdir(parents=True, exist_ok=True)
        engine = create_engine(
            parsed, poolclass=NullPool, connect_args={"timeout": _BUSY_TIMEOUT_S}
        )

        @event.listens_for(engine, "connect")
        def _connect(dbapi_connection, _record):
            dbapi_connection.isolation_level = None  # SQLAlchemy, not pysqlite, begins
            dbapi_connection.execute("PRAGMA foreign_keys = ON")
            dbapi_connection.execute("PRAGMA journal_mode = WAL")

        @event.listens_for(engine, "begin")
        def _begin(connection):
            write = connection.get_execution_options().get("history_write", False)
            connection.exec_driver_sql("BEGIN IMMEDIATE" if write else "BEGIN")

        return engine
    if parsed.get_backend_name() == "postgresql":
        if parsed.drivername == "postgresql":
            parsed = parsed.set(drivername="postgresql+psycopg")
        try:
            return create_engine(parsed, poolclass=NullPool, connect_args={"connect_timeout": 10})
        except ModuleNotFoundError as err:
            raise EnvironmentFailure(
                f"database {url!r}: the driver {err.name} is not installed "
                "(pip install 'psycopg[binary]')"
            ) from None
    raise InputError(
        f"database URL {url!r}: {parsed.get_backend_name()} is not supported "
        "(a SQLite file or postgresql://...)"
    )


def writer(engine: Engine) -> Engine:
    """``engine`` for a write transaction (on SQLite it begins with ``BEGIN IMMEDIATE``;
    reads begin with a plain ``BEGIN`` and never wait for a writer in WAL mode)."""
    return engine.execution_options(history_write=True)


def migrate(engine: Engine, revision: str = HEAD) -> None:
    """Upgrade the database to ``revision`` (default: the current schema)."""
    config = Config()
    config.set_main_option("script_location", str(_MIGRATIONS))
    with writer(engine).connect() as connection:
        config.attributes["connection"] = connection
        command.upgrade(config, revision)


def open_history(db: str | os.PathLike | None = None, *, revision: str = HEAD) -> Engine:
    """The history database as an engine, migrated to ``revision``.

    Raises
    ------
    InputError
        The URL is not one, names an unsupported database, or the server does not answer.
    """
    url = database_url(db)
    engine = _engine(url)
    try:
        migrate(engine, revision)
    except OperationalError as err:
        reason = " ".join(str(err.orig).split()) if err.orig is not None else str(err)
        shown = make_url(url).render_as_string(hide_password=True)
        raise InputError(f"database {shown}: does not answer ({reason})") from None
    return engine


def schema_revision(engine: Engine) -> str | None:
    """The revision the database is at (None for an empty one)."""
    with engine.connect() as connection:
        if not inspect(connection).has_table("alembic_version"):
            return None
        return connection.exec_driver_sql("SELECT version_num FROM alembic_version").scalar()
