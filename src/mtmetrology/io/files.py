"""Output files that are complete or absent, and the checks before a run writes anything.

Outputs are written atomically: the content goes to an anonymous temporary file in the
target's directory (Linux ``O_TMPFILE``: it has no name, so a killed process leaves
nothing behind), which is given a name only when complete and then renamed onto the
target (``os.replace``).  Where anonymous files are not supported the temporary file is
named ``.<target>.<pid>.tmp``; such leftovers of processes that no longer run are swept
before the next write to the same directory.  An interrupted or failed run therefore
leaves the previous target, or no target, never a partial one.

:func:`check_output` refuses, before any computation, an output that would overwrite an
input, a directory, a read-only file or a file in a directory that does not exist (it is
not created silently).
"""

from __future__ import annotations

import errno
import os
import re
from collections.abc import Iterable, Iterator
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import IO

from mtmetrology.errors import EnvironmentFailure, InputError

__all__ = ["InputFileError", "atomic_write", "check_output", "sweep_temporaries"]


class InputFileError(InputError):
    """A user file that cannot be used; the message names file, line and field."""


def _temporary_pattern(name: str) -> re.Pattern:
    return re.compile(rf"^\.{re.escape(name)}\.(\d+)\.[0-9a-z]+\.tmp$")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def sweep_temporaries(path: str | os.PathLike) -> list[Path]:
    """Remove ``.<name>.<pid>.*.tmp`` files beside ``path`` left by processes that are gone.

    Returns the paths removed.
    """
    target = Path(path)
    pattern = _temporary_pattern(target.name)
    removed = []
    with suppress(OSError):
        for entry in target.parent.iterdir():
            m = pattern.match(entry.name)
            if m and not _alive(int(m.group(1))):
                with suppress(OSError):
                    entry.unlink()
                    removed.append(entry)
    return removed


def check_output(path: str | os.PathLike, inputs: Iterable[str | os.PathLike] = ()) -> Path:
    """Refuse an output path before any work is done.

    Parameters
    ----------
    path : path-like
        The file a command will write.
    inputs : iterable of path-like
        The files the command reads: the output must be none of them.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        The output is an input, a directory, a read-only file, or lies in a directory
        that does not exist.
    """
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{p}: is a directory; give a file name for the output")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.is_dir():
        raise InputError(f"{p}: the directory {parent} does not exist (it is not created)")
    for source in inputs:
        s = Path(source)
        if s.exists() and p.exists() and os.path.samefile(s, p):
            raise InputError(f"{p}: the output would overwrite the input {s}")
    if p.exists() and not os.access(p, os.W_OK):
        raise InputError(f"{p}: the file is read-only")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{p}: the directory {parent} is not writable")
    return p


def _anonymous(directory: Path) -> int | None:
    """An O_TMPFILE descriptor in ``directory``, or None where unsupported."""
    flag = getattr(os, "O_TMPFILE", None)
    if flag is None:
        return None
    try:
        return os.open(directory, flag | os.O_WRONLY, 0o666)
    except OSError as err:
        if err.errno in (errno.EOPNOTSUPP, errno.EISDIR, errno.EINVAL, errno.ENOENT):
            return None
        raise


@contextmanager
def atomic_write(
    path: str | os.PathLike, mode: str = "w", encoding: str | None = "utf-8"
) -> Iterator[IO]:
    """Open an anonymous temporary file beside ``path``; give it ``path`` on success.

    On any exception (KeyboardInterrupt included) nothing is linked and ``path`` is
    untouched.  The directory must exist (see :func:`check_output`).

    Raises
    ------
    EnvironmentFailure
        The directory cannot be written (permissions, full disk ...).
    """
    target = Path(path)
    directory = target.parent if str(target.parent) else Path(".")
    if not directory.is_dir():
        raise InputError(f"{target}: the directory {directory} does not exist (it is not created)")
    sweep_temporaries(target)
    named = directory / f".{target.name}.{os.getpid()}.{os.urandom(4).hex()}.tmp"
    kwargs = {} if "b" in mode else {"encoding": encoding, "newline": ""}
    try:
        fd = _anonymous(directory)
        anonymous = fd is not None
        if fd is None:
            fd = os.open(named, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
    except OSError as err:
        raise EnvironmentFailure(f"{target}: cannot write in {directory}: {err.strerror}") from None
    try:
        with os.fdopen(fd, mode, **kwargs) as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
            if anonymous:
                os.link(f"/proc/self/fd/{fh.fileno()}", named, follow_symlinks=True)
        os.replace(named, target)
    except BaseException as err:
        with suppress(OSError):
            named.unlink()
        if isinstance(err, OSError) and not isinstance(err, InputError):
            raise EnvironmentFailure(f"{target}: cannot write: {err.strerror or err}") from None
        raise
