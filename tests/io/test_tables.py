"""The strict CSV reader and the vectorised writer (mtmetrology.io.tables)."""

from __future__ import annotations

import csv
import io

import numpy as np
import pyarrow as pa
import pytest

from mtmetrology.io import InputFileError, format_decimal, read_csv_table, write_columns


def _write(tmp_path, text: str | bytes, name="t.csv"):
    p = tmp_path / name
    if isinstance(text, str):
        p.write_text(text, encoding="utf-8", newline="")
    else:
        p.write_bytes(text)
    return p


def test_unusual_but_valid_files_read_as_the_plain_one(tmp_path):
    plain = read_csv_table(_write(tmp_path, "X,Y,id\n1,2,00\n3.5,-4e-1,07\n", "plain.csv"))
    unusual = (
        "\ufeff# exported by a probing cycle\r\n"
        "  X , Y ,id, extra\r\n"
        "\r\n"
        " 1 ,2,00,a\r\n"
        "# a comment between rows\r\n"
        ",,,\r\n"
        "3.5,-4e-1,07,b"  # no final line end
    )
    t = read_csv_table(_write(tmp_path, unusual, "unusual.csv"), required=["X", "Y"])
    assert t.header == ("X", "Y", "id", "extra")
    np.testing.assert_array_equal(t.floats("X"), plain.floats("X"))
    np.testing.assert_array_equal(t.floats("Y"), plain.floats("Y"))
    assert t.strings("id") == plain.strings("id") == ["00", "07"]
    np.testing.assert_array_equal(t.lines, [4, 7])
    np.testing.assert_array_equal(plain.lines, [2, 3])


def test_cr_only_line_ends_read_as_the_plain_file_with_editor_line_numbers(tmp_path):
    """Old Mac exports end lines with a bare CR (issue 18 §3: an internal csv error before)."""
    plain = read_csv_table(_write(tmp_path, "X,Y,id\n1,2,00\n\n3.5,-4e-1,07\n", "plain.csv"))
    cr = read_csv_table(_write(tmp_path, b"X,Y,id\r1,2,00\r\r3.5,-4e-1,07\r", "cr.csv"))
    assert cr.header == plain.header == ("X", "Y", "id")
    np.testing.assert_array_equal(cr.floats("Y"), plain.floats("Y"))
    assert cr.strings("id") == ["00", "07"]
    np.testing.assert_array_equal(cr.lines, plain.lines)
    np.testing.assert_array_equal(cr.lines, [2, 4])
    with pytest.raises(InputFileError) as err:
        read_csv_table(_write(tmp_path, b"X,Y\r1,2\r3,x\r", "bad.csv")).floats("Y")
    assert str(err.value).endswith("bad.csv, line 3: column 'Y' holds 'x', not a number")


@pytest.mark.parametrize(
    ("cell", "why"),
    [
        ("1_000", "underscore"),
        ("\u0661\u0662", "Arabic-Indic digits"),
        ("\uff11\uff12", "full-width digits"),
        ("0x10", "hexadecimal"),
        ('"1,5"', "decimal comma"),
        ("1d5", "Fortran exponent"),
        ("", "empty"),
        ("--1", "double sign"),
        ("1.2.3", "two points"),
    ],
)
def test_cells_python_float_may_accept_are_refused_with_their_line(tmp_path, cell, why):
    p = _write(tmp_path, f"x,y\n1,2\n3,4\n{cell},5\n6,7\n")
    with pytest.raises(InputFileError) as err:
        read_csv_table(p).floats("x")
    assert str(err.value).startswith(f"{p}, line 4: column 'x'"), why


@pytest.mark.parametrize("cell", ["nan", "NaN", "inf", "-Infinity", "1e400", "1e308", "-2e9"])
def test_non_finite_and_huge_values_are_refused(tmp_path, cell):
    p = _write(tmp_path, f"x\n1\n{cell}\n")
    with pytest.raises(InputFileError, match=r"line 3: column 'x'"):
        read_csv_table(p).floats("x")
    assert np.isnan(read_csv_table(p).floats("x", allow_nan=True)[1]) == (cell.lower() == "nan")


def test_bounds_name_the_line_and_the_range(tmp_path):
    p = _write(tmp_path, "X\n-220\n230\n1e6\n")
    with pytest.raises(InputFileError) as err:
        read_csv_table(p).floats("X", bounds=(-220.0, 230.0), unit="mm")
    assert str(err.value) == f"{p}, line 4: column 'X' = 1e6 mm lies outside [-220, 230] mm"


@pytest.mark.parametrize(
    ("text", "line"),
    [
        ("x,x\n1,2\n", 1),  # duplicated header
        ("x,,y\n1,2,3\n", 1),  # empty column name
        ("x,y\n1,2\n3,4,5\n", 3),  # ragged, too many
        ("x,y\n1,2\n\n3\n", 4),  # ragged, too few (after a blank line)
    ],
)
def test_header_and_row_shape_errors_name_the_line(tmp_path, text, line):
    p = _write(tmp_path, text)
    with pytest.raises(InputFileError, match=rf"^{p}, line {line}: "):
        read_csv_table(p)


def test_invalid_utf8_names_its_line(tmp_path):
    p = _write(tmp_path, b"x,id\n1,a\n2,\xff\xfe\n")
    with pytest.raises(InputFileError, match=rf"^{p}, line 3: not UTF-8 text"):
        read_csv_table(p)


def test_file_level_errors(tmp_path):
    with pytest.raises(InputFileError, match="file not found"):
        read_csv_table(tmp_path / "none.csv")
    with pytest.raises(InputFileError, match="is a directory"):
        read_csv_table(tmp_path)
    with pytest.raises(InputFileError, match="no header line"):
        read_csv_table(_write(tmp_path, "# only a comment\n\n"))
    with pytest.raises(InputFileError, match="0 data rows, at least 1 needed"):
        read_csv_table(_write(tmp_path, "x,y\n"))
    assert len(read_csv_table(_write(tmp_path, "x,y\n"), min_rows=0)) == 0
    with pytest.raises(InputFileError, match=r"missing column 'z' \(columns present: x, y\)"):
        read_csv_table(_write(tmp_path, "x,y\n1,2\n"), required=["z"])


def test_write_columns_round_trips_through_the_standard_csv_module():
    rng = np.random.default_rng(7)
    values = rng.normal(scale=300.0, size=1000)
    ids = pa.array([f"b{i}" if i % 7 else f'odd, "{i}"' for i in range(1000)])
    out = io.BytesIO()
    n = write_columns(out, {"id": ids, "v": format_decimal(values, 6)})
    rows = list(csv.reader(io.StringIO(out.getvalue().decode())))
    assert n == 1000 and rows[0] == ["id", "v"]
    assert [r[0] for r in rows[1:]] == ids.to_pylist()
    np.testing.assert_allclose([float(r[1]) for r in rows[1:]], values, atol=5e-7, rtol=0)


def test_format_decimal_rounds_and_never_writes_minus_zero():
    assert format_decimal(np.array([-1e-9, 2.5e-7, 1.0000004]), 6).to_pylist() == [
        "0",
        "0",
        "1",
    ]
