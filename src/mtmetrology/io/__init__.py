"""Readers, writers and file schemas."""

from mtmetrology._lazy import lazy_exports

_EXPORTS = {
    "load_document": "mtmetrology.io.documents",
    "parse_document": "mtmetrology.io.documents",
    "InputFileError": "mtmetrology.io.files",
    "atomic_write": "mtmetrology.io.files",
    "check_output": "mtmetrology.io.files",
    "sweep_temporaries": "mtmetrology.io.files",
    "write_json": "mtmetrology.io.files",
    "Table": "mtmetrology.io.tables",
    "format_decimal": "mtmetrology.io.tables",
    "read_csv_table": "mtmetrology.io.tables",
    "write_columns": "mtmetrology.io.tables",
    "write_csv_table": "mtmetrology.io.tables",
}

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

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
