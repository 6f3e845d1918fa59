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

import ctypes
import errno
import json
import os
import re
from collections.abc import Iterable, Iterator
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import IO

from mtmetrology.errors import EnvironmentFailure, InputError

__all__ = [
    "InputFileError",
    "atomic_write",
    "check_output",
    "committed",
    "sweep_temporaries",
    "write_json",
]

_COMMITTED: list[Path] = []


def committed() -> tuple[Path, ...]:
    """The targets :func:`atomic_write` completed in this process (for an interrupted
    command to say truthfully whether something was written)."""
    return tuple(_COMMITTED)


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
    # A file without any write permission bit is read-only, even for root (who may
    # write it): the mark says it is not to be replaced.
    if p.exists() and (not os.access(p, os.W_OK) or not p.stat().st_mode & 0o222):
        raise InputError(f"{p}: the file is read-only; choose another output")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise InputError(f"{p}: the directory {parent} is not writable")
    return p


_AT_FDCWD = -100
_AT_EMPTY_PATH = 0x1000
_LINKABLE: dict[int, bool] = {}  # st_dev -> whether an anonymous file can be named there


def _link(fd: int, destination: Path) -> None:
    """Give the anonymous file ``fd`` the name ``destination``.

    ``linkat`` through ``/proc/self/fd`` is the unprivileged way (open(2), O_TMPFILE);
    where /proc is not that of this process's mount namespace it fails with EXDEV, and
    ``linkat(fd, "", ..., AT_EMPTY_PATH)`` (which needs CAP_DAC_READ_SEARCH) is tried.
    """
    try:
        os.link(f"/proc/self/fd/{fd}", destination, follow_symlinks=True)
        return
    except OSError as err:
        first = err
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.linkat(fd, b"", _AT_FDCWD, os.fsencode(destination), _AT_EMPTY_PATH) != 0:
        raise first


def _anonymous(directory: Path) -> int | None:
    """An O_TMPFILE descriptor in ``directory`` that :func:`_link` can name, or None."""
    flag = getattr(os, "O_TMPFILE", None)
    if flag is None:
        return None
    try:
        device = directory.stat().st_dev
        fd = os.open(directory, flag | os.O_WRONLY, 0o666)
    except OSError as err:
        if err.errno in (errno.EOPNOTSUPP, errno.EISDIR, errno.EINVAL, errno.ENOENT):
            return None
        raise
    if device not in _LINKABLE:  # probe once per file system
        probe = directory / f".mtm-probe.{os.getpid()}.{os.urandom(4).hex()}.tmp"
        try:
            _link(fd, probe)
            probe.unlink()
            _LINKABLE[device] = True
        except OSError:
            _LINKABLE[device] = False
            os.close(fd)
            return None
        os.close(fd)
        fd = os.open(directory, flag | os.O_WRONLY, 0o666)
    if not _LINKABLE[device]:
        os.close(fd)
        return None
    return fd


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
                _link(fh.fileno(), named)
        os.replace(named, target)
        _COMMITTED.append(target)
    except BaseException as err:
        with suppress(OSError):
            named.unlink()
        if isinstance(err, OSError) and not isinstance(err, InputError):
            raise EnvironmentFailure(f"{target}: cannot write: {err.strerror or err}") from None
        raise


def write_json(path: str | os.PathLike, document: dict) -> None:
    """Write a JSON document atomically (NaN is refused: it is never a result)."""
    text = json.dumps(document, indent=2, ensure_ascii=False, allow_nan=False)
    with atomic_write(path) as fh:
        fh.write(text + "\n")
