"""Calibration history: a database of machines, calibrations, task and verification results.

Above the applications (beside ``report``): it reads their results through their documented
JSON forms and no application imports it. SQLite by default, PostgreSQL by URL; the schema
is migrated with Alembic on opening (:func:`open_history`).
"""

from mtmetrology.history.analysis import (
    TrendResult,
    long_term_covariance,
    parameter_drift,
    parameter_trend,
)
from mtmetrology.history.database import DB_ENV, database_url, open_history
from mtmetrology.history.dcc import (
    CalibrationCertificate,
    calibration_certificate,
    read_certificate,
)
from mtmetrology.history.drift import DriftResult, fit_drift
from mtmetrology.history.records import (
    RunRecord,
    RunSummary,
    add_result,
    export_rows,
    list_runs,
    show_run,
)

__all__ = [
    "DB_ENV",
    "CalibrationCertificate",
    "DriftResult",
    "RunRecord",
    "RunSummary",
    "TrendResult",
    "add_result",
    "calibration_certificate",
    "database_url",
    "export_rows",
    "fit_drift",
    "list_runs",
    "long_term_covariance",
    "open_history",
    "parameter_drift",
    "parameter_trend",
    "read_certificate",
    "show_run",
]
