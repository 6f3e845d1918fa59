"""The output directory of ``mtm export``: one run's files, recorded in a manifest.

A control directory that holds the tables of two runs is a trap: a re-export of a
three-axis machine after a run that wrote ``y.comp`` and ``z.comp`` must not leave them
beside the new files.  So the directory of an export holds the files of one run only:

- an absent directory is created (its parent must exist), an empty one is used;
- a directory holding the files of a previous export, as listed in its manifest
  :data:`MANIFEST` (``files``, ``format``, ``written``), is refused unless ``force``;
  with ``force`` exactly those files are removed before the new ones are written;
- a directory holding any other entry (a file no manifest lists, a sub-directory) is
  refused, with or without ``force``: nothing of it is removed or overwritten, and no
  export is mixed with foreign files.  Copy the tables from the export directory into
  the control's configuration.

The manifest is written before the files it lists, so that a run stopped half-way
leaves a directory the next ``force`` run can clear.
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from mtmetrology.errors import InputError
from mtmetrology.io.files import write_json

__all__ = ["KIND", "MANIFEST", "OutputPlan", "commit_output", "plan_output"]

MANIFEST = "mtm-export-manifest.json"
KIND = "mtm-export-manifest"
VERSION = 1


@dataclass(frozen=True)
class OutputPlan:
    """What an export will do in its directory.

    Attributes
    ----------
    directory : Path
    create : bool
        The directory does not exist yet.
    previous : tuple of str
        Files of the previous run (its manifest) present now, removed before writing.
    files : tuple of str
        The files this run writes (the manifest not included).
    """

    directory: Path
    create: bool
    previous: tuple
    files: tuple


def _is_name(name: object) -> bool:
    return (
        isinstance(name, str)
        and name not in ("", ".", "..", MANIFEST)
        and "/" not in name
        and os.sep not in name
        and "\0" not in name
    )


def _previous(directory: Path) -> list[str]:
    """The files the manifest of ``directory`` lists (refused when it is not one)."""
    path = directory / MANIFEST
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise InputError(f"{path}: not a readable export manifest ({err})") from None
    if not isinstance(doc, dict) or doc.get("kind") != KIND:
        raise InputError(f"{path}: kind: not an {KIND}")
    files = doc.get("files")
    if not isinstance(files, list):
        raise InputError(f"{path}: files: must be a list of file names")
    for k, name in enumerate(files):
        if not _is_name(name):
            raise InputError(f"{path}: files[{k}]: {name!r} is not a file name of {directory}")
    return files


def plan_output(directory: str | os.PathLike, files: Sequence[str], *, force: bool) -> OutputPlan:
    """Check the output directory of an export before anything is computed or written.

    Parameters
    ----------
    directory : path-like
    files : sequence of str
        The names this run will write.
    force : bool
        Replace the files of a previous export (its manifest).

    Returns
    -------
    OutputPlan

    Raises
    ------
    InputError
        The path is a file, its parent does not exist, the directory holds files of a
        previous run without ``force``, or any entry no manifest lists (module notes).
    """
    d = Path(directory)
    if not d.exists():
        parent = d.parent if str(d.parent) else Path(".")
        if not parent.is_dir():
            raise InputError(f"-o: {d}: its directory {parent} does not exist (it is not created)")
        return OutputPlan(d, True, (), tuple(files))
    if not d.is_dir():
        raise InputError(f"-o: {d}: is not a directory")
    entries = sorted(p.name for p in d.iterdir())
    if not entries:
        return OutputPlan(d, False, (), tuple(files))
    listed = _previous(d) if MANIFEST in entries else []
    foreign = [n for n in entries if n != MANIFEST and n not in listed]
    if foreign:
        raise InputError(
            f"-o: {d} holds {foreign[0]!r}"
            + (f" and {len(foreign) - 1} more" if len(foreign) > 1 else "")
            + f", not written by an export ({MANIFEST} does not list it); an export "
            "directory holds one run's files only: choose an empty directory"
        )
    if not force:
        raise InputError(
            f"-o: {d} holds the files of a previous export ({MANIFEST}); --force replaces them"
        )
    for name in listed:
        if (d / name).is_dir() and not (d / name).is_symlink():
            raise InputError(f"{d / MANIFEST}: lists {name!r}, which is a directory")
    present = tuple(n for n in listed if n in entries)
    return OutputPlan(d, False, present, tuple(files))


def commit_output(plan: OutputPlan, fmt: str, command: str = "") -> None:
    """Create the directory, remove the previous run's files, write the new manifest.

    Called once everything is computed and checked, just before the files are written.
    """
    if plan.create:
        plan.directory.mkdir()
    for name in plan.previous:
        (plan.directory / name).unlink(missing_ok=True)
    write_json(
        plan.directory / MANIFEST,
        {
            "kind": KIND,
            "version": VERSION,
            "format": fmt,
            "written": datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "command": command,
            "files": sorted(plan.files),
        },
    )
