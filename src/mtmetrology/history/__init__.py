"""Calibration history: a database of machines, calibrations, task and verification results.

Above the applications (beside ``report``): it reads their results through their documented
JSON forms and no application imports it. SQLite by default, PostgreSQL by URL; the schema
revision is checked on opening and migrated by a writer (:func:`open_history`).

The names below are imported on first use (PEP 562): ``mtm history list`` loads the
database layer and the records, not the drift model, SciPy or the certificates.
"""

from importlib import import_module

_WHERE = {
    "TrendResult": "analysis",
    "long_term_covariance": "analysis",
    "parameter_drift": "analysis",
    "parameter_trend": "analysis",
    "parameter_trends": "analysis",
    "DB_ENV": "database",
    "database_url": "database",
    "open_history": "database",
    "CalibrationCertificate": "dcc",
    "calibration_certificate": "dcc",
    "read_certificate": "dcc_read",
    "DriftResult": "drift",
    "fit_drift": "drift",
    "RunRecord": "records",
    "RunSummary": "records",
    "add_result": "records",
    "add_results": "records",
    "export_rows": "series",
    "list_runs": "records",
    "show_run": "records",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module 'mtmetrology.history' has no attribute {name!r}")
    value = getattr(import_module(f"mtmetrology.history.{_WHERE[name]}"), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted([*globals(), *_WHERE])
