"""An uploaded result document recorded as ``mtm history add`` records a file.

The bytes are read as ``load_document`` reads a file (UTF-8, at most ``MAX_BYTES``, the same
strict parser :func:`mtmetrology.io.documents.parse_document`), the machine is the one the
document names, and :func:`mtmetrology.history.add_result` validates and stores it in one
transaction. On the server only the preset machines are known (a machine named by a file
path is refused: the server reads no file a document names). A machine the history does not
hold yet is created by an administrator's upload only. One audit row, written in the same
transaction as the run, records the upload: who, the file name, its SHA-256 and the run it
became.
"""

from __future__ import annotations

import hashlib
from datetime import UTC, datetime

from mtmetrology.errors import InputError
from mtmetrology.history.records import RunRecord, add_result
from mtmetrology.history.series import machine_names
from mtmetrology.io.documents import MAX_BYTES, parse_document

__all__ = ["upload_result"]


def upload_result(
    engine,
    data: bytes,
    filename: str,
    *,
    user,
    note: str | None = None,
    date: str | None = None,
    temperature_c: float | None = None,
) -> RunRecord:
    """Record an uploaded result (``mtm history add`` of the same bytes) and audit it.

    Raises
    ------
    InputError
        Not UTF-8, too large, not a result document, a machine that is not a preset, a
        machine new to the history uploaded by someone who is not an administrator, a bad
        date, or any refusal of :func:`~mtmetrology.history.add_result`.
    PermissionError
        A new machine uploaded by a non-administrator.
    """
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.preset_registry import list_presets

    source = "".join(c if c.isalnum() or c in "-_. " else "_" for c in filename)[:100]
    if len(data) > MAX_BYTES:
        raise InputError(f"{source}: {len(data)} bytes is too large ({MAX_BYTES} at most)")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise InputError(f"{source}: not UTF-8 text (byte {err.start})") from None
    document = parse_document(text, source)
    if not isinstance(document, dict) or not isinstance(document.get("kind"), str):
        raise InputError(f"{source}: not a result document (a JSON mapping with a kind)")
    name = document.get("machine")
    if not isinstance(name, str):
        raise InputError(f"{source}: machine: missing (the server needs the machine named)")
    if name not in list_presets():
        raise InputError(
            f"{source}: machine {name!r}: the server knows the presets only "
            f"({', '.join(list_presets())})"
        )
    new_machine = name not in machine_names(engine)
    if new_machine and user.role != "admin":
        raise PermissionError(
            f"machine {name!r} is not in the history yet: only an administrator adds a machine"
        )
    when = None
    if date:
        try:
            when = datetime.fromisoformat(date)
        except ValueError:
            raise InputError(f"date {date!r}: not an ISO 8601 date (2026-03-01T08:30)") from None
        # the instant in UTC (naive: UTC), so that every backend stores the same instant
        when = when.replace(tzinfo=UTC) if when.tzinfo is None else when.astimezone(UTC)
    return add_result(
        engine,
        document,
        Machine.load(name),
        source=source,
        performed_at=when,
        note=note,
        temperature_c=temperature_c,
        by=user.username,
        action="upload",
        detail={"sha256": hashlib.sha256(data).hexdigest()},
    )
