"""CSV tables read strictly and fast, and written in one vectorised pass.

Records files hold up to millions of rows, and a number computed from a malformed cell is
worse than no number, so the reader is both a C parser (Apache Arrow) and strict:

- the header is the first line that is neither blank nor a ``#`` comment; column names
  are stripped (padded headers are fine) and must be unique and non-empty;
- blank lines and ``#`` comment lines are skipped anywhere; a UTF-8 byte-order mark and
  CRLF line ends are accepted; extra columns are kept and ignored by the commands;
- every row must have as many fields as the header (the error names the line);
- numbers follow the C grammar ``[+-]digits[.digits][e[+-]digits]`` (or ``nan``/``inf``,
  refused unless asked for): ``1_000``, ``1,5``, ``0x10``, Arabic-Indic or full-width
  digits, which Python's ``float()`` accepts, are refused with the line and column.
  Surrounding spaces are allowed.

Columns stay as compact Arrow string arrays until a command asks for them as numbers
(:meth:`Table.floats`) or text (:meth:`Table.strings`), so identifiers such as ``00``
keep their form.  Writing joins columns with Arrow's vectorised kernels
(:func:`format_decimal`, :func:`write_rows`); a million rows read, computed and written
takes about a second.
"""

from __future__ import annotations

import csv
import io
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv

from mtmetrology.io.files import InputFileError, atomic_write

__all__ = ["Table", "format_decimal", "read_csv_table", "write_csv_table", "write_rows"]

_NUMBER = (
    r"^[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?$"
    r"|^[+-]?(?i:nan|inf|infinity)$"
)
_SPACE = np.frombuffer(b" \t\r", dtype=np.uint8)


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
    """

    def __init__(self, path: str, header: Sequence[str], columns: dict, lines: np.ndarray, raw):
        self.path = path
        self.header = tuple(header)
        self._columns = columns
        self.lines = lines
        self._raw = raw

    def __len__(self) -> int:
        return int(self.lines.size)

    def has(self, name: str) -> bool:
        return name in self._columns

    def _column(self, name: str) -> pa.Array:
        try:
            return self._columns[name]
        except KeyError:
            raise InputFileError(
                f"{self.path}: missing column {name!r} (columns present: {', '.join(self.header)})"
            ) from None

    def strings(self, name: str) -> list[str]:
        """A column as stripped strings."""
        return pc.utf8_trim_whitespace(self._column(name)).to_pylist()

    def floats(
        self,
        name: str,
        *,
        allow_nan: bool = False,
        bounds: tuple[float, float] | None = None,
        unit: str = "",
    ) -> np.ndarray:
        """A column as float64, refusing any cell that is not a finite C-grammar number.

        Parameters
        ----------
        name : str
        allow_nan : bool
            Accept NaN and infinities.
        bounds : (low, high), optional
            Inclusive range every value must lie in (e.g. an axis travel).
        unit : str
            Unit shown with the bounds in the error.

        Raises
        ------
        InputFileError
            Naming the file, the line, the column and the cell.
        """
        col = pc.utf8_trim_whitespace(self._column(name))
        try:
            values = pc.cast(col, pa.float64()).to_numpy(zero_copy_only=False)
        except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
            ok = pc.match_substring_regex(col, _NUMBER).to_numpy(zero_copy_only=False)
            i = int(np.argmin(ok))
            cell = col[i].as_py()
            what = "an empty cell" if cell == "" else f"{cell!r}"
            raise InputFileError(
                f"{self.path}, line {self.lines[i]}: column {name!r} holds {what}, not a number"
            ) from None
        if not allow_nan:
            bad = ~np.isfinite(values)
            if bad.any():
                i = int(np.argmax(bad))
                raise InputFileError(
                    f"{self.path}, line {self.lines[i]}: column {name!r} is {col[i].as_py()!r}; "
                    "NaN and infinite values are not accepted"
                )
        if bounds is not None:
            low, high = bounds
            out = (values < low) | (values > high)
            if out.any():
                i = int(np.argmax(out))
                u = f" {unit}" if unit else ""
                raise InputFileError(
                    f"{self.path}, line {self.lines[i]}: column {name!r} = {values[i]:g}{u} lies "
                    f"outside [{low:g}, {high:g}]{u}"
                )
        return values

    def raw_rows(self) -> pa.Array:
        """The text of every data row as written in the file (without line end)."""
        return self._raw


def _line_layout(buf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end (exclusive, line end removed) of every line of a byte buffer."""
    newlines = np.flatnonzero(buf == 0x0A)
    starts = np.concatenate([[0], newlines + 1])
    ends = np.concatenate([newlines, [buf.size]])
    if starts[-1] == buf.size:  # the file ends with a newline
        starts, ends = starts[:-1], ends[:-1]
    cr = (ends > starts) & (buf[np.maximum(ends - 1, 0)] == 0x0D)
    ends = ends - cr
    return starts, ends


def _classify(buf: np.ndarray, starts: np.ndarray, ends: np.ndarray):
    """(blank, comment) masks: blank lines hold only spaces, tabs and commas; comment lines
    start with '#' after optional spaces."""
    content = np.flatnonzero(~np.isin(buf, np.concatenate([_SPACE, [0x2C]])))
    first = np.searchsorted(content, starts)
    has = first < content.size
    first_pos = np.where(has, content[np.minimum(first, max(content.size - 1, 0))], buf.size)
    blank = ~has | (first_pos >= ends)
    visible = np.flatnonzero(~np.isin(buf, _SPACE))
    first_v = np.searchsorted(visible, starts)
    has_v = first_v < visible.size
    pos_v = np.where(has_v, visible[np.minimum(first_v, max(visible.size - 1, 0))], buf.size)
    comment = ~blank & (pos_v < ends) & (buf[np.minimum(pos_v, buf.size - 1)] == 0x23)
    return blank, comment


def _ragged_line(path: Path, text: str, line_numbers: np.ndarray, width: int) -> str:
    """Find the first data row whose field count differs from the header (error path)."""
    for k, row in enumerate(csv.reader(io.StringIO(text))):
        if len(row) != width:
            return f"{path}, line {line_numbers[k]}: {len(row)} fields where the header has {width}"
    return f"{path}: a row does not match the header ({width} fields)"


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

    Raises
    ------
    InputFileError
        Missing file, bad header, ragged row, invalid text, missing column, too few rows.
    """
    p = Path(path)
    if p.is_dir():
        raise InputFileError(f"{p}: is a directory, not a CSV file")
    if not p.is_file():
        raise InputFileError(f"{p}: file not found")
    data = p.read_bytes()
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    buf = np.frombuffer(data, dtype=np.uint8)
    starts, ends = _line_layout(buf)
    blank, comment = _classify(buf, starts, ends)
    keep = np.flatnonzero(~blank & ~comment)
    if keep.size == 0:
        raise InputFileError(f"{p}: empty file (no header line)")
    h = keep[0]
    try:
        header_text = data[starts[h] : ends[h]].decode("utf-8")
    except UnicodeDecodeError:
        raise InputFileError(f"{p}, line {h + 1}: not UTF-8 text") from None
    header = [c.strip() for c in next(csv.reader([header_text]))]
    if any(not c for c in header):
        raise InputFileError(f"{p}, line {h + 1}: an empty column name in the header")
    dup = sorted({c for c in header if header.count(c) > 1})
    if dup:
        raise InputFileError(f"{p}, line {h + 1}: column {dup[0]!r} appears twice in the header")
    rows = keep[1:]
    line_numbers = rows + 1
    if rows.size < min_rows:
        raise InputFileError(f"{p}: {rows.size} data rows, at least {min_rows} needed")
    for name in required:
        if name not in header:
            raise InputFileError(
                f"{p}: missing column {name!r} (columns present: {', '.join(header)})"
            )
    # The data rows as one '\n'-separated buffer (comment and blank lines dropped).
    lengths = ends[rows] - starts[rows]
    take = np.zeros(buf.size + 1, dtype=np.int32)
    np.add.at(take, starts[rows], 1)
    np.add.at(take, ends[rows], -1)
    mask = np.cumsum(take[:-1]) > 0
    body = buf[mask]
    offsets = np.zeros(rows.size + 1, dtype=np.int64)
    np.cumsum(lengths, out=offsets[1:])
    try:
        raw = pa.StringArray.from_buffers(
            rows.size, pa.py_buffer(offsets.astype(np.int32)), pa.py_buffer(body.tobytes())
        )
        raw.validate(full=True)
    except pa.ArrowInvalid:
        bad = next(i for i in range(rows.size) if not _utf8(data[starts[rows[i]] : ends[rows[i]]]))
        raise InputFileError(f"{p}, line {line_numbers[bad]}: not UTF-8 text") from None
    joined = pc.binary_join_element_wise(raw, pa.scalar(""), "\n")
    text_bytes = pa.py_buffer(b"".join([b for b in [_concatenated(joined)]]))
    try:
        arrow = pacsv.read_csv(
            pa.BufferReader(text_bytes),
            read_options=pacsv.ReadOptions(column_names=header, block_size=1 << 24),
            parse_options=pacsv.ParseOptions(newlines_in_values=False),
            convert_options=pacsv.ConvertOptions(
                column_types={c: pa.string() for c in header},
                strings_can_be_null=False,
                quoted_strings_can_be_null=False,
            ),
        )
    except pa.ArrowInvalid:
        text = text_bytes.to_pybytes().decode("utf-8")
        raise InputFileError(_ragged_line(p, text, line_numbers, len(header))) from None
    if arrow.num_rows != rows.size:
        raise InputFileError(
            f"{p}: {arrow.num_rows} rows parsed for {rows.size} lines (a quoted field spans "
            "lines?)"
        )
    columns = {c: arrow.column(c).combine_chunks() for c in header}
    return Table(str(p), header, columns, line_numbers, raw)


def _utf8(b: bytes) -> bool:
    try:
        b.decode("utf-8")
    except UnicodeDecodeError:
        return False
    return True


def _concatenated(strings: pa.Array) -> bytes:
    """The values of a string array back to back, as one bytes object."""
    if len(strings) == 0:
        return b""
    offsets = strings.buffers()[1]
    data = strings.buffers()[2]
    width = 8 if pa.types.is_large_string(strings.type) else 4
    first = int(np.frombuffer(offsets, dtype=f"<i{width}")[strings.offset])
    last = int(np.frombuffer(offsets, dtype=f"<i{width}")[strings.offset + len(strings)])
    return data.to_pybytes()[first:last]


def format_decimal(values: np.ndarray, decimals: int) -> pa.Array:
    """Numbers rounded to ``decimals`` and written in their shortest form (``200.02``)."""
    v = np.round(np.asarray(values, dtype=float), decimals) + 0.0  # + 0.0: no "-0"
    return pc.cast(pa.array(v), pa.string())


def write_rows(fh, header: Sequence[str], columns: Sequence) -> int:
    """Write a header and rows made of string columns joined by commas.

    Parameters
    ----------
    fh : binary file
    header : sequence of str
    columns : sequence of pyarrow string arrays (or lists of str), one per output column
        (a column may itself hold several comma-joined fields, e.g. raw input rows).

    Returns
    -------
    int
        Number of rows written.
    """
    out = io.StringIO()
    csv.writer(out, lineterminator="\n").writerow(list(header))
    fh.write(out.getvalue().encode("utf-8"))
    arrays = [c if isinstance(c, pa.Array) else pa.array(c, type=pa.string()) for c in columns]
    if not arrays or len(arrays[0]) == 0:
        return 0
    rows = pc.binary_join_element_wise(*arrays, pa.scalar(""), ",")
    # binary_join_element_wise left a trailing ',' from the empty last element: replace
    # the separator with the line end by joining again on '\n' per row.
    lines = pc.binary_join_element_wise(
        pc.utf8_slice_codeunits(rows, 0, -1), pa.scalar(""), "\n"
    )
    fh.write(_concatenated(lines))
    return len(lines)


def write_csv_table(path: str | os.PathLike, header: Sequence[str], rows) -> None:
    """Write a small CSV file atomically from Python rows (a list of sequences)."""
    with atomic_write(path) as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(list(header))
        for r in rows:
            w.writerow(list(r))
