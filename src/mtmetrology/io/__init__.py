"""Readers, writers and file schemas."""

from mtmetrology.io.documents import load_document, parse_document
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
    "load_document",
    "parse_document",
    "read_csv_table",
    "write_csv_table",
    "write_json",
]
