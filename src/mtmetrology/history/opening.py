"""What opening the calibration history needs, without SQLAlchemy.

Where the database is (:func:`database_url`: ``--db``, ``$MTMETROLOGY_DB`` or the default
file), the schema revisions this version knows (:data:`HEAD` is the current one), how a
SQLite file is opened and configured (:func:`sqlite_open`, :func:`sqlite_configure`: both
drivers, SQLAlchemy's engine of :mod:`mtmetrology.history.database` and the
:mod:`sqlite3` driver of :mod:`mtmetrology.history.sql`, open it with these), and the one
rule that turns a fault of the database driver into a refusal (:func:`database_fault`; see
:mod:`mtmetrology.history.database`). Importing this module costs the standard library
only: ``mtm history list`` reads these before it knows whether it needs SQLAlchemy.
"""

from __future__ import annotations

import hashlib
import json
import os
import sqlite3
from pathlib import Path

from mtmetrology.errors import EnvironmentFailure, InputError

__all__ = [
    "BUSY_TIMEOUT_S",
    "DB_ENV",
    "HEAD",
    "REVISIONS",
    "canonical_sha256",
    "database_fault",
    "database_url",
    "default_location",
    "read_only_medium",
    "sqlite_configure",
    "sqlite_open",
]

#: Environment variable naming the history database (a file or a URL).
DB_ENV = "MTMETROLOGY_DB"
#: The schema revisions this version knows, oldest first; the last is the current one.
REVISIONS = ("0001", "0002", "0003", "0004", "0005")
#: The current schema revision.
HEAD = REVISIONS[-1]
BUSY_TIMEOUT_S = 60.0
#: Driver messages of faults of the machine (exit 3); any other is a fault of the database.
_ENVIRONMENT = (
    ("database or disk is full", "the disk is full"),
    ("no space left", "the disk is full"),
    ("readonly database", "the file or its directory is read-only"),
    ("read-only", "the file or its directory is read-only"),
    ("unable to open database file", "the file cannot be opened (permissions or directory)"),
    ("disk i/o error", "input/output error of the disk"),
    ("database is locked", "locked by another process beyond the busy timeout"),
    ("connection", "does not answer"),
    ("could not connect", "does not answer"),
    ("timeout", "does not answer"),
    ("permission denied", "permission denied"),
)
#: SQLite's words for faults the file system names better (:func:`_file_system`).
_AMBIGUOUS = ("unable to open database file", "disk i/o error", "readonly database")
_DATABASE = (
    ("file is not a database", "not a database (or a corrupted one)"),
    ("malformed", "corrupted or truncated"),
    ("no such table", "a table of the history is missing (the database was altered)"),
    ("no such column", "a column of the history is missing (the database was altered)"),
    ("does not exist", "a table or database does not exist"),
    ("append-only", "the amendments and the audit log are append-only"),
)


def canonical_sha256(document: dict) -> str:
    """SHA-256 of ``document`` as canonical JSON (sorted keys, no spaces, UTF-8)."""
    text = json.dumps(document, sort_keys=True, separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(text.encode()).hexdigest()


def default_location() -> Path:
    """The default SQLite file, in the user's data directory."""
    import platformdirs

    return Path(platformdirs.user_data_dir("mtmetrology", appauthor=False)) / "history.sqlite"


def database_url(db: str | os.PathLike | None = None) -> str:
    """The URL of the history database: ``db``, else ``$MTMETROLOGY_DB``, else the default
    file. A plain path (no ``://``) is a SQLite file."""
    chosen = str(db) if db is not None else os.environ.get(DB_ENV) or str(default_location())
    if "://" in chosen:
        return chosen
    return f"sqlite:///{Path(chosen).expanduser().resolve()}"


def _file_system(path: str) -> str | None:
    """What the file system says of a SQLite file's place: read-only, full, or nothing.

    SQLite reports a full disk under a WAL file as "disk I/O error" and a read-only file
    system as "unable to open database file"; the file system says which it is."""
    try:
        state = os.statvfs(Path(path).parent)
    except OSError:
        return None
    if state.f_flag & os.ST_RDONLY:
        return "on a read-only file system"
    free = state.f_bavail * state.f_frsize
    if free < 1 << 20:
        return f"the disk is full ({free // 1024} KiB free)"
    if Path(path).exists() and not os.access(path, os.W_OK):
        return "the file is read-only"
    return None


def _integrity(err: BaseException) -> bool:
    """A violated constraint: the DBAPI's ``IntegrityError`` (psycopg raises subclasses,
    ``UniqueViolation``...) or SQLAlchemy's wrapper of one."""
    return any(c.__name__ == "IntegrityError" for c in type(err).__mro__)


def database_fault(
    database: str, err: BaseException, path: str | None = None
) -> InputError | EnvironmentFailure:
    """The one refusal for a fault of the database driver (see
    :mod:`mtmetrology.history.database`).

    Parameters
    ----------
    database : str
        The file or URL as a person names it (a SQLite URL's file, a URL without password).
    err : BaseException
        The DBAPI exception (``sqlite3`` or ``psycopg``), or SQLAlchemy's wrapper of it.
    path : str, optional
        The SQLite file: a fault of the machine is then named from its file system
        (read-only, full) when the driver's words do not say it.

    Returns
    -------
    InputError or EnvironmentFailure
        One line: ``database <where>: <what> (<driver's words>)``.
    """
    original = getattr(err, "orig", None) or err
    words = " ".join(str(original).split())[:200]
    lowered = words.lower()
    if _integrity(err) or _integrity(original):
        return InputError(f"database {database}: a constraint of the history fails ({words})")
    for needle, what in _DATABASE:
        if needle in lowered:
            return InputError(f"database {database}: {what} ({words})")
    needle = next((needle for needle, _ in _ENVIRONMENT if needle in lowered), None)
    what = dict(_ENVIRONMENT).get(needle)
    if path is not None and (needle is None or needle in _AMBIGUOUS):
        what = _file_system(path) or what
    if what is not None:
        return EnvironmentFailure(f"database {database}: {what} ({words})")
    if isinstance(original, OSError) or type(original).__name__ == "OperationalError":
        return EnvironmentFailure(f"database {database}: {words}")
    return InputError(f"database {database}: cannot be used as a history ({words})")


def read_only_medium(path: str) -> bool:
    """Whether an existing SQLite file sits on a read-only file system (a CD, a snapshot, a
    read-only mount): nobody can write it, so it is read as immutable."""
    try:
        return Path(path).is_file() and bool(os.statvfs(Path(path).parent).f_flag & os.ST_RDONLY)
    except OSError:
        return False


def sqlite_open(path: str, frozen: bool) -> sqlite3.Connection:
    """A :mod:`sqlite3` connection to ``path`` with the busy timeout; ``frozen``, a file on
    a read-only medium, opened read-only and immutable (WAL needs a ``-shm`` file that
    cannot be made there; no writer can exist)."""
    if frozen:
        from urllib.parse import quote

        uri = f"file:{quote(path)}?mode=ro&immutable=1"
        return sqlite3.connect(uri, uri=True, check_same_thread=False, timeout=BUSY_TIMEOUT_S)
    return sqlite3.connect(path, check_same_thread=False, timeout=BUSY_TIMEOUT_S)


def sqlite_configure(raw: sqlite3.Connection, frozen: bool) -> None:
    """Configure a new SQLite connection as the history uses it (both drivers: SQLAlchemy's
    engine calls this on connecting): no implicit transactions (the history begins: ``BEGIN
    IMMEDIATE`` for a write), foreign keys on, the WAL journal (not on a frozen file).

    Raises
    ------
    sqlite3.Error
        The caller maps it (:func:`database_fault`).
    """
    raw.isolation_level = None
    raw.execute("PRAGMA foreign_keys = ON")
    if not frozen:
        raw.execute("PRAGMA journal_mode = WAL")
