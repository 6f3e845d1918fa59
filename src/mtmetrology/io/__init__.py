"""Readers, writers and file schemas."""

from mtmetrology.io.documents import load_document, parse_document
from mtmetrology.io.files import (
    InputFileError,
    atomic_write,
    check_output,
    sweep_temporaries,
    write_json,
)
from mtmetrology.io.tables import (
    Table,
    format_decimal,
    read_csv_table,
    write_columns,
    write_csv_table,
)

__all__ = [
    "InputFileError",
    "Table",
    "atomic_write",
    "check_output",
    "format_decimal",
    "load_document",
    "parse_document",
    "read_csv_table",
    "sweep_temporaries",
    "write_columns",
    "write_csv_table",
    "write_json",
]
