"""Readers, writers and file schemas."""

from mtmetrology.io.files import (
    InputFileError,
    Table,
    atomic_write,
    read_csv_table,
    write_csv_table,
    write_json,
)

__all__ = [
    "InputFileError",
    "Table",
    "atomic_write",
    "read_csv_table",
    "write_csv_table",
    "write_json",
]
