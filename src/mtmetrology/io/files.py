"""File helpers shared by every layer: atomic writes and validated table reading.

Outputs are written atomically (temporary file in the same folder, then
``os.replace``), so an interrupted run never leaves a half-written result.
Tables are read with errors that name the file, the line and the column.
"""

from __future__ import annotations

import csv
import json
import math
import os
import tempfile
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import IO

import numpy as np

from mtmetrology.errors import InputError

__all__ = [
    "InputFileError",
    "Table",
    "atomic_write",
    "read_csv_table",
    "write_csv_table",
    "write_json",
]


class InputFileError(InputError):
    """A user file that cannot be used; the message names file, line and field."""


@contextmanager
def atomic_write(
    path: str | os.PathLike, mode: str = "w", encoding: str | None = "utf-8"
) -> Iterator[IO]:
    """Open a temporary file beside ``path``; rename it onto ``path`` on success.

    On any exception the temporary file is removed and ``path`` is untouched. The file
    gets the permissions of an ordinary new file (0666 less the umask), not the 0600 of
    a temporary file.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.chmod(tmp, 0o666 & ~_umask())
        kwargs = {} if "b" in mode else {"encoding": encoding, "newline": ""}
        with os.fdopen(fd, mode, **kwargs) as fh:
            yield fh
        os.replace(tmp, path)
    except BaseException:
        with _suppress():
            os.unlink(tmp)
        raise


def _umask() -> int:
    """The process umask (read by setting it and restoring it at once)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


@contextmanager
def _suppress():
    try:
        yield
    except OSError:
        pass


def write_json(path: str | os.PathLike, document: dict) -> None:
    """Write a JSON document atomically (NaN is refused: it is never a result)."""
    text = json.dumps(document, indent=2, allow_nan=False)
    with atomic_write(path) as fh:
        fh.write(text + "\n")


class Table:
    """Columns of a CSV file: named float columns and string columns, with line numbers.

    Attributes
    ----------
    path : str
        The file read.
    header : list of str
        Column names in file order.
    rows : list of list of str
        Raw cells, for copying input columns to an output.
    lines : ndarray of int
        The 1-based file line of each row.
    """

    def __init__(self, path: str, header: list[str], rows: list[list[str]], lines: list[int]):
        self.path = path
        self.header = header
        self.rows = rows
        self.lines = np.asarray(lines, dtype=int)

    def __len__(self) -> int:
        return len(self.rows)

    def has(self, name: str) -> bool:
        return name in self.header

    def strings(self, name: str) -> list[str]:
        """A column as strings; a missing column is an :class:`InputFileError`."""
        j = self._index(name)
        return [r[j].strip() for r in self.rows]

    def floats(self, name: str, *, allow_nan: bool = False) -> np.ndarray:
        """A column as float64, with an error naming file, line and column on bad cells."""
        j = self._index(name)
        out = np.empty(len(self.rows))
        for i, r in enumerate(self.rows):
            cell = r[j].strip()
            try:
                v = float(cell)
            except ValueError:
                raise InputFileError(
                    f"{self.path}, line {self.lines[i]}: column {name!r} holds {cell!r}, "
                    "not a number"
                ) from None
            if not allow_nan and not math.isfinite(v):
                raise InputFileError(
                    f"{self.path}, line {self.lines[i]}: column {name!r} is {cell!r}; "
                    "NaN and infinite values are not accepted"
                )
            out[i] = v
        return out

    def _index(self, name: str) -> int:
        try:
            return self.header.index(name)
        except ValueError:
            raise InputFileError(
                f"{self.path}: missing column {name!r} (columns present: {', '.join(self.header)})"
            ) from None


def read_csv_table(
    path: str | os.PathLike, required: Sequence[str] = (), *, min_rows: int = 1
) -> Table:
    """Read a CSV file with a header line; blank lines and ``#`` comments are skipped.

    Parameters
    ----------
    path : path-like
        The CSV file.
    required : sequence of str
        Columns that must be present.
    min_rows : int
        Fewest data rows accepted.

    Raises
    ------
    InputFileError
        Missing file, missing column, ragged row, or too few rows.
    """
    p = Path(path)
    if not p.is_file():
        raise InputFileError(f"{p}: file not found")
    header: list[str] | None = None
    rows: list[list[str]] = []
    lines: list[int] = []
    with p.open(newline="", encoding="utf-8-sig") as fh:
        for lineno, row in enumerate(csv.reader(fh), start=1):
            if not row or all(not c.strip() for c in row) or row[0].lstrip().startswith("#"):
                continue
            if header is None:
                header = [c.strip() for c in row]
                continue
            if len(row) != len(header):
                raise InputFileError(
                    f"{p}, line {lineno}: {len(row)} fields where the header has {len(header)}"
                )
            rows.append(row)
            lines.append(lineno)
    if header is None:
        raise InputFileError(f"{p}: empty file (no header line)")
    table = Table(str(p), header, rows, lines)
    for name in required:
        table._index(name)
    if len(rows) < min_rows:
        raise InputFileError(f"{p}: {len(rows)} data rows, at least {min_rows} needed")
    return table


def write_csv_table(
    path: str | os.PathLike, header: Sequence[str], rows: Iterable[Sequence[object]]
) -> None:
    """Write a CSV file atomically."""
    with atomic_write(path) as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(list(header))
        for r in rows:
            w.writerow(list(r))
