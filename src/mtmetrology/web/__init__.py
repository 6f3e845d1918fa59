"""The laboratory's web application (``mtm serve``): machines, due dates, trends, reports
and certificates in a browser, with users, roles and an append-only audit trail.

Above :mod:`mtmetrology.history` and :mod:`mtmetrology.report`: every number comes from the
same library calls as ``mtm history`` (trend, drift model, covariance, DCC). Loaded only by
``mtm serve`` (FastAPI, uvicorn, argon2-cffi are imported here and nowhere else).
"""

from mtmetrology.web.app import create_app

__all__ = ["create_app"]
