"""CSV tables read strictly and fast, and written in one vectorised pass.

Records files hold up to millions of rows, and a number computed from a malformed cell is
worse than no number, so the reader is both a C parser (Apache Arrow) and strict:

- the header is the first line that is neither blank nor a ``#`` comment; column names
  are stripped (padded headers are fine) and must be unique and non-empty;
- blank lines (only spaces, tabs or commas) and ``#`` comment lines are skipped anywhere;
  a UTF-8 byte-order mark, CRLF and CR-only line ends (old Mac exports) are accepted;
  extra columns are kept;
- every row must have as many fields as the header (the error names the line);
- numbers follow the C grammar ``[+-]digits[.digits][e[+-]digits]`` of Arrow's parser:
  ``1_000``, ``1,5``, ``0x10``, Arabic-Indic or full-width digits, which Python's
  ``float()`` accepts, are refused with the line and column; NaN, infinities, and
  magnitudes beyond :data:`MAX_MAGNITUDE` are refused unless asked for.  ASCII spaces
  and tabs around a cell are allowed (a no-break space is not).

Columns stay as compact Arrow string arrays until a command asks for them as numbers
(:meth:`Table.floats`) or text (:meth:`Table.strings`), so identifiers such as ``00``
keep their form.  :func:`write_columns` writes columns in chunks with Arrow's vectorised
string kernels, quoting only the cells that need it.

Examples
--------
>>> import tempfile, pathlib
>>> d = pathlib.Path(tempfile.mkdtemp())
>>> _ = (d / "points.csv").write_text("# probe run 3\\n x , y ,id\\n1.5,2,00\\n\\n-3e-1,4,07\\n")
>>> t = read_csv_table(d / "points.csv", required=["x", "y"])
>>> t.floats("x"), t.strings("id"), t.lines
(array([ 1.5, -0.3]), ['00', '07'], array([3, 5]))
>>> _ = (d / "bad.csv").write_text("x\\n1\\n1_000\\n")
>>> try:
...     read_csv_table(d / "bad.csv").floats("x")
... except InputFileError as err:
...     print(str(err).replace(str(d), "DIR"))
DIR/bad.csv, line 3: column 'x' holds '1_000', not a number
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import IO, TYPE_CHECKING

import numpy as np

from mtmetrology.io.files import InputFileError, atomic_write

if TYPE_CHECKING:  # pyarrow loads when a table is read or written: --help needs none
    import pyarrow as pa

__all__ = [
    "MAX_MAGNITUDE",
    "Table",
    "format_decimal",
    "read_csv_table",
    "write_columns",
    "write_csv_table",
]

#: Largest magnitude :meth:`Table.floats` accepts by default.  No length in mm, angle in
#: degrees or coordinate of a metrology file comes near it, while squares and products of
#: larger values (1e308 ...) overflow or swamp every result computed from them.
MAX_MAGNITUDE = 1e9

_BOM = b"\xef\xbb\xbf"
# First bytes of a line that may be blank or a comment: tab, LF, CR, space, '#', ','.
_MAYBE_SKIPPED = np.array([0x09, 0x0A, 0x0D, 0x20, 0x23, 0x2C], dtype=np.uint8)
_NEEDS_QUOTES = r'[,"\r\n]'
_CHUNK_ROWS = 1 << 17
_SCAN_BYTES = 1 << 22


def _skipped(line: bytes) -> bool:
    """A blank line (spaces, tabs, commas only) or a ``#`` comment."""
    return not line.strip(b" \t\r\n,") or line.lstrip(b" \t").startswith(b"#")


class Table:
    """Columns of a CSV file, with the file line of every data row.

    Attributes
    ----------
    path : str
        The file read.
    header : tuple of str
        Column names in file order (stripped).
    lines : (n,) ndarray of int
        The 1-based file line of each data row.
    text : pyarrow.Table
        The cells as written (string columns named by ``header``).
    quoted : bool
        Whether the file holds a double quote at all; without one no cell can hold a
        comma or a line end, and :func:`write_columns` need not look for them.
    """

    def __init__(
        self,
        path: str,
        header: Sequence[str],
        text: pa.Table,
        lines: np.ndarray,
        quoted: bool = True,
    ):
        self.path = path
        self.header = tuple(header)
        self.text = text
        self.lines = lines
        self.quoted = quoted

    def __len__(self) -> int:
        return int(self.lines.size)

    def has(self, name: str) -> bool:
        """Whether the file has a column ``name``."""
        return name in self.header

    def take(self, rows: Sequence[int] | np.ndarray) -> Table:
        """The data rows ``rows`` (0-based indices) as a table, with their file lines."""
        import pyarrow as pa

        rows = np.asarray(rows, dtype=np.intp)
        return Table(
            self.path, self.header, self.text.take(pa.array(rows)), self.lines[rows], self.quoted
        )

    def _column(self, name: str) -> pa.ChunkedArray:
        if name not in self.header:
            raise InputFileError(
                f"{self.path}: missing column {name!r} (columns present: {', '.join(self.header)})"
            )
        return self.text.column(name)

    def strings(self, name: str) -> list[str]:
        """A column as stripped strings (raises :class:`InputFileError` if missing)."""
        return _trim(self._column(name)).to_pylist()

    def vectors(self, names: Sequence[str], **options) -> np.ndarray:
        """Several float columns side by side, ``(n, len(names))`` (e.g. ``"ijk"``, an
        approach direction); ``options`` as :meth:`floats`, which checks each column."""
        return np.column_stack([self.floats(name, **options) for name in names])

    def floats(
        self,
        name: str,
        *,
        allow_nan: bool = False,
        bounds: tuple[float, float] | None = None,
        unit: str = "",
    ) -> np.ndarray:
        """A column as float64, refusing any cell that is not a number it may hold.

        Parameters
        ----------
        name : str
            The column.
        allow_nan : bool
            Accept NaN and infinities (and any magnitude).
        bounds : (low, high), optional
            Inclusive range every value must lie in (e.g. an axis travel), in the file's
            unit; by default ``[-MAX_MAGNITUDE, MAX_MAGNITUDE]``.
        unit : str
            Unit shown with the bounds in the error.

        Returns
        -------
        (n,) ndarray of float

        Raises
        ------
        InputFileError
            Naming the file, the line, the column and the cell.
        """
        import pyarrow as pa
        import pyarrow.compute as pc

        col = self._column(name)
        try:
            values = pc.cast(col, pa.float64()).to_numpy(zero_copy_only=False)
        except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
            values = None  # padded cells (" 1.5 ") or not numbers at all: look closer
        if values is None:
            col = _trim(col)
            try:
                values = pc.cast(col, pa.float64()).to_numpy(zero_copy_only=False)
            except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
                values = None
        if values is None:
            i = _first_unparsable(col)
            cell = col[i].as_py()
            what = "an empty cell" if cell == "" else repr(cell)
            raise InputFileError(
                f"{self.path}, line {self.lines[i]}: column {name!r} holds {what}, not a number"
            ) from None
        if allow_nan:
            return values
        bad = ~np.isfinite(values)
        if bad.any():
            i = int(np.argmax(bad))
            raise InputFileError(
                f"{self.path}, line {self.lines[i]}: column {name!r} is {col[i].as_py()!r}; "
                "NaN, infinite and out-of-range values are not accepted"
            )
        low, high = (-MAX_MAGNITUDE, MAX_MAGNITUDE) if bounds is None else bounds
        out = (values < low) | (values > high)
        if out.any():
            i = int(np.argmax(out))
            u = f" {unit}" if unit else ""
            raise InputFileError(
                f"{self.path}, line {self.lines[i]}: column {name!r} = {col[i].as_py()}{u} lies "
                f"outside [{low:g}, {high:g}]{u}"
            )
        return values


def _trim(column):
    """Cells without the ASCII spaces and tabs around them (not Unicode spaces: a
    no-break space is no padding a number may carry)."""
    import pyarrow.compute as pc

    return pc.utf8_trim(column, characters=" \t")


def _first_unparsable(col: pa.Array) -> int:
    """Index of the first cell Arrow cannot cast to float64 (bisection; error path only)."""
    import pyarrow as pa
    import pyarrow.compute as pc

    lo, hi = 0, len(col)  # invariant: col[lo:hi] holds the first bad cell
    while hi - lo > 1:
        mid = (lo + hi) // 2
        try:
            pc.cast(col.slice(lo, mid - lo), pa.float64())
            lo = mid
        except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
            hi = mid
    return lo


def _read_bytes(p: Path) -> bytes:
    if p.is_dir():
        raise InputFileError(f"{p}: is a directory, not a CSV file")
    try:
        data = p.read_bytes()
    except FileNotFoundError:
        raise InputFileError(f"{p}: file not found") from None
    except OSError as err:
        raise InputFileError(f"{p}: cannot read the file ({err.strerror})") from None
    data = data[3:] if data.startswith(_BOM) else data
    if data.count(b"\r") != data.count(b"\r\n"):
        # A CR that does not start a CRLF ends a line (classic Mac OS): one line end per CR,
        # so that line numbers in messages count as an editor shows them.
        data = data.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    return data


def _header(p: Path, data: bytes) -> tuple[int, list[str], int]:
    """(1-based line of the header, stripped names, offset of the next line)."""
    pos, lineno = 0, 0
    while pos < len(data):
        end = data.find(b"\n", pos)
        end = len(data) if end < 0 else end
        line, lineno, pos = data[pos:end], lineno + 1, end + 1
        if _skipped(line):
            continue
        try:
            text = line.decode("utf-8")
        except UnicodeDecodeError:
            raise InputFileError(f"{p}, line {lineno}: not UTF-8 text") from None
        header = [c.strip() for c in next(csv.reader([text]))]
        if any(not c for c in header):
            raise InputFileError(f"{p}, line {lineno}: an empty column name in the header")
        dup = next((c for c in header if header.count(c) > 1), None)
        if dup is not None:
            raise InputFileError(f"{p}, line {lineno}: column {dup!r} appears twice in the header")
        return lineno, header, min(pos, len(data))
    raise InputFileError(f"{p}: empty file (no header line)")


def _body(data: bytes, offset: int) -> tuple[pa.Buffer, np.ndarray, np.ndarray]:
    """The data rows without blank and comment lines (one buffer), their 0-based line
    index after the header, and the byte offset in ``data[offset:]`` of every body line."""
    import pyarrow as pa

    buf = np.frombuffer(data, dtype=np.uint8, offset=offset)
    # Line ends found a block at a time: no byte-sized mask of the whole file in memory.
    newlines = np.concatenate(
        [np.zeros(0, dtype=np.int64)]
        + [
            np.flatnonzero(buf[k : k + _SCAN_BYTES] == 0x0A) + k
            for k in range(0, buf.size, _SCAN_BYTES)
        ]
    )
    starts = np.concatenate([[0], newlines + 1])
    del newlines
    if starts[-1] == buf.size:  # a final line end does not start a line
        starts = starts[:-1]
    stops = np.append(starts[1:], buf.size)  # line ends included
    maybe = np.flatnonzero(np.isin(buf[starts], _MAYBE_SKIPPED)) if starts.size else starts
    drop = [int(i) for i in maybe if _skipped(bytes(buf[starts[i] : stops[i]]))]
    if not drop:
        return pa.py_buffer(buf), np.arange(starts.size), starts
    keep = np.ones(buf.size, dtype=bool)
    for i in drop:
        keep[starts[i] : stops[i]] = False
    rows = np.delete(np.arange(starts.size), drop)
    return pa.py_buffer(buf[keep]), rows, starts


def _ragged(p: Path, data: bytes, offset: int, starts, rows, lines, width: int) -> str:
    """The first data row whose field count differs from the header (error path)."""
    body = data[offset:]
    stops = [*starts[1:], len(body)]
    for i, lineno in zip(rows, lines, strict=True):
        raw = body[starts[i] : stops[i]]
        try:
            fields = next(csv.reader([raw.decode("utf-8").rstrip("\r\n")]), [])
        except UnicodeDecodeError:
            return f"{p}, line {lineno}: not UTF-8 text"
        except csv.Error as err:
            return f"{p}, line {lineno}: {err}"
        if len(fields) != width:
            return f"{p}, line {lineno}: {len(fields)} fields where the header has {width}"
    return f"{p}: a quoted field spans lines or a row does not match the {width}-column header"


def read_csv_table(
    path: str | os.PathLike, required: Sequence[str] = (), *, min_rows: int = 1
) -> Table:
    """Read a CSV file with a header line (see the module notes for the rules).

    Parameters
    ----------
    path : path-like
        The CSV file.
    required : sequence of str
        Columns that must be present.
    min_rows : int
        Fewest data rows accepted.

    Returns
    -------
    Table

    Raises
    ------
    InputFileError
        Missing file, bad header, ragged row, invalid text, missing column, too few rows.
    """
    import pyarrow as pa
    import pyarrow.csv as pacsv

    p = Path(path)
    data = _read_bytes(p)
    header_line, header, offset = _header(p, data)
    for name in required:
        if name not in header:
            raise InputFileError(
                f"{p}: missing column {name!r} (columns present: {', '.join(header)})"
            )
    body, rows, starts = _body(data, offset)
    lines = rows + header_line + 1
    if rows.size < min_rows:
        raise InputFileError(f"{p}: {rows.size} data rows, at least {min_rows} needed")
    if rows.size == 0:
        text = pa.table({c: pa.array([], pa.string()) for c in header})
        return Table(str(p), header, text, lines, quoted=False)
    try:
        text = pacsv.read_csv(
            pa.BufferReader(body),
            read_options=pacsv.ReadOptions(
                column_names=header, use_threads=False, block_size=1 << 22
            ),
            parse_options=pacsv.ParseOptions(newlines_in_values=False, ignore_empty_lines=False),
            convert_options=pacsv.ConvertOptions(
                column_types={c: pa.string() for c in header},
                strings_can_be_null=False,
                quoted_strings_can_be_null=False,
            ),
        )
    except pa.ArrowInvalid:
        raise InputFileError(_ragged(p, data, offset, starts, rows, lines, len(header))) from None
    if text.num_rows != rows.size:
        raise InputFileError(_ragged(p, data, offset, starts, rows, lines, len(header)))
    return Table(str(p), header, text, lines, quoted=data.find(b'"', offset) >= 0)


def format_decimal(values: np.ndarray, decimals: int) -> pa.Array:
    """Numbers rounded to ``decimals`` and written in their shortest form.

    Examples
    --------
    >>> format_decimal(np.array([200.0200001, -1e-9, 3.0]), 6).to_pylist()
    ['200.02', '0', '3']
    """
    import pyarrow as pa
    import pyarrow.compute as pc

    v = np.round(np.asarray(values, dtype=float), decimals) + 0.0  # + 0.0: no "-0"
    return pc.cast(pa.array(v), pa.string())


def _quoted(column: pa.Array) -> pa.Array:
    """Cells holding a comma, quote or line end quoted as CSV requires."""
    import pyarrow as pa
    import pyarrow.compute as pc

    column = column if pa.types.is_string(column.type) else pc.cast(column, pa.string())
    needs = pc.match_substring_regex(column, _NEEDS_QUOTES)
    if not pc.any(needs).as_py():
        return column
    escaped = pc.replace_substring(column, '"', '""')
    wrapped = pc.binary_join_element_wise('"', escaped, '"', "")
    return pc.if_else(needs, wrapped, column)


def write_columns(
    fh: IO[bytes],
    columns: Mapping[str, pa.Array | pa.ChunkedArray | np.ndarray],
    *,
    decimals: int = 6,
    plain: Sequence[str] = (),
) -> int:
    """Write a header and the rows of equally long columns to a binary file, in chunks.

    Parameters
    ----------
    fh : binary file
        Usually the handle of :func:`mtmetrology.io.files.atomic_write` opened ``"wb"``.
    columns : mapping of str to pyarrow string arrays or float ndarrays, length n each
        Output columns in order: text (e.g. ``table.text`` columns) or numbers, written
        by :func:`format_decimal` with ``decimals`` one chunk at a time.
    decimals : int
        Decimals of the number columns.
    plain : sequence of str
        Text columns known to hold no comma, quote or line end (not searched for them;
        see :attr:`Table.quoted`).

    Returns
    -------
    int
        Number of rows written.
    """
    import pyarrow.compute as pc

    names = list(columns)
    out = io.StringIO()
    csv.writer(out, lineterminator="\n").writerow(names)
    fh.write(out.getvalue().encode("utf-8"))
    arrays = [columns[c] for c in names]
    n = len(arrays[0]) if arrays else 0
    for start in range(0, n, _CHUNK_ROWS):
        parts = []
        for name, a in zip(names, arrays, strict=True):
            if isinstance(a, np.ndarray):
                parts.append(format_decimal(a[start : start + _CHUNK_ROWS], decimals))
            elif name in plain:
                parts.append(_flat(a.slice(start, _CHUNK_ROWS)))
            else:
                parts.append(_quoted(_flat(a.slice(start, _CHUNK_ROWS))))
        rows = pc.binary_join_element_wise(*parts, ",")
        fh.write(_data(pc.binary_join_element_wise(rows, "", "\n")))  # "row" + "\n" + ""
    return n


def _flat(column):
    import pyarrow as pa

    return column.combine_chunks() if isinstance(column, pa.ChunkedArray) else column


def _data(strings: pa.Array) -> memoryview:
    """The bytes of a string array's values back to back."""
    offsets = np.frombuffer(strings.buffers()[1], dtype=np.int32)
    first, last = offsets[strings.offset], offsets[strings.offset + len(strings)]
    return memoryview(strings.buffers()[2])[first:last]


def write_csv_table(
    path: str | os.PathLike, header: Sequence[str], rows: Sequence[Sequence[object]]
) -> None:
    """Write a small CSV file atomically from Python rows (a sequence of sequences)."""
    with atomic_write(path) as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(list(header))
        for r in rows:
            w.writerow(list(r))
