"""The JSON API under ``/api/v1``: the same data as the pages, for automation.

Every route needs ``Authorization: Bearer mtm_…`` (an API token of an active user, not
revoked; cookies are not accepted here, so no cross-site request can use a browser's
session and the API needs no CSRF token). Results are the documents the command line
prints with ``--json`` (``history-run``, ``history-trend``, ``history-drift``, a parameter
set for the covariance); ``GET /api/v1/openapi.json`` is the schema.
"""

from __future__ import annotations

import base64
import binascii
from typing import Annotated, Literal

from fastapi import APIRouter, Depends, Query, Request
from fastapi.responses import JSONResponse, Response
from pydantic import BaseModel, Field
from sqlalchemy.orm import Session

from mtmetrology.errors import InputError
from mtmetrology.history.amendments import amend_run, show_amended
from mtmetrology.history.analysis import long_term_covariance
from mtmetrology.history.audit import audit_entries
from mtmetrology.history.records import list_runs
from mtmetrology.history.settings import lab_settings
from mtmetrology.web import security
from mtmetrology.web.figures import certificate_xml
from mtmetrology.web.security import Refused
from mtmetrology.web.upload import upload_result

router = APIRouter(prefix="/api/v1", tags=["api"])
Category = Literal["calibration", "task", "verification"]


def token_user(request: Request):
    """The user of the request's bearer token; Refused(401) otherwise."""
    header = request.headers.get("authorization", "")
    scheme, _, secret = header.partition(" ")
    user = None
    if scheme.lower() == "bearer" and secret:
        user = security.token_user(request.app.state.engine, secret.strip())
    if user is None:
        raise Refused(401, "a valid API token is needed (Authorization: Bearer mtm_...)")
    return user


def engineer(user=Depends(token_user)):  # noqa: B008 (FastAPI dependency)
    """The token's user, who must be an engineer or administrator."""
    if not security.may(user, "engineer"):
        raise Refused(403, f"{user.username} ({user.role}): this needs the engineer role")
    return user


Viewer = Annotated[object, Depends(token_user)]
Engineer = Annotated[object, Depends(engineer)]


@router.get("/openapi.json", include_in_schema=False)
def openapi(request: Request, _: Viewer):
    return JSONResponse(request.app.openapi())


@router.get("/machines")
def machines(request: Request, _: Viewer) -> list[dict]:
    """Every machine: calibrations, last calibration, due date, status."""
    return [m.to_dict() for m in request.app.state.lab.overview()]


@router.get("/machines/{name}")
def machine(request: Request, name: str, _: Viewer) -> dict:
    """One machine: its overview and each parameter's control chart summary and due date."""
    lab = request.app.state.lab
    overview = lab.machine(name).to_dict()
    overview["parameters"] = [
        {
            "parameter": r["parameter"],
            "trend": None if r["trend"] is None else _trend_summary(r["trend"]),
            "drift": None if r["drift"] is None else r["drift"].to_dict(),
        }
        for r in lab.parameter_table(name)
    ]
    overview["runs"] = [
        r.to_dict()
        for c in ("calibration", "task", "verification")
        for r in list_runs(lab.engine, machine=name, category=c)
    ]
    return overview


def _trend_summary(trend) -> dict:
    doc = trend.to_dict()
    doc["latest"] = doc["runs"][-1]
    doc["out_of_control_runs"] = [r["id"] for r in doc.pop("runs") if r["out_of_control"]]
    return doc


@router.get("/machines/{name}/trend")
def trend(
    request: Request, name: str, parameter: Annotated[str, Query(max_length=50)], _: Viewer
) -> dict:
    """The parameter's control chart (``history-trend``) and its drift (where an MPE is set)."""
    row = next(
        (r for r in request.app.state.lab.parameter_table(name) if r["parameter"] == parameter),
        None,
    )
    if row is None or row["trend"] is None:
        raise InputError(f"parameter {parameter!r}: no control chart for {name!r}")
    doc = row["trend"].to_dict()
    doc["drift"] = None if row["drift"] is None else row["drift"].to_dict()
    return doc


@router.get("/machines/{name}/covariance")
def covariance(request: Request, name: str, _: Viewer) -> dict:
    """The long-term covariance of the machine's calibrations (a parameter set)."""
    return long_term_covariance(request.app.state.engine, name).to_document()


@router.get("/runs/{category}/{run_id}")
def run(request: Request, category: Category, run_id: int, _: Viewer) -> dict:
    """One run (``history-run``) with its amendments."""
    record, amendments = show_amended(request.app.state.engine, run_id, category)
    return {**record.to_dict(), "amendments": [a.to_dict() for a in amendments]}


@router.get("/runs/{category}/{run_id}/certificate.xml")
def certificate(request: Request, category: Category, run_id: int, _: Viewer):
    """The run's DCC, validated against the DCC 3.1.2 schema before it is sent."""
    engine = request.app.state.engine
    record, _ = show_amended(engine, run_id, category)
    return Response(certificate_xml(record, lab_settings(engine)), media_type="application/xml")


class Upload(BaseModel):
    """A result document to record (``content``: the file's bytes, base64)."""

    filename: str = Field(max_length=200)
    content_base64: str
    note: str | None = Field(default=None, max_length=2000)
    date: str | None = Field(default=None, max_length=40)


@router.post("/runs", status_code=201)
def add(request: Request, body: Upload, user: Engineer) -> dict:
    """Record a result document, as ``mtm history add`` (engineer)."""
    try:
        data = base64.b64decode(body.content_base64, validate=True)
    except (binascii.Error, ValueError):
        raise InputError("content_base64: not base64") from None
    record = upload_result(
        request.app.state.engine, data, body.filename, user=user, note=body.note, date=body.date
    )
    return record.to_dict()


class AmendmentIn(BaseModel):
    """New values (None: unchanged) and the reason."""

    why: str = Field(min_length=1, max_length=2000)
    date: str | None = Field(default=None, max_length=40)
    note: str | None = Field(default=None, max_length=2000)
    temperature: float | None = None
    operator: str | None = Field(default=None, max_length=200)


@router.post("/runs/{category}/{run_id}/amendments", status_code=201)
def amend(
    request: Request, category: Category, run_id: int, body: AmendmentIn, user: Engineer
) -> list[dict]:
    """Amend a run's metadata (``mtm history amend``; engineer)."""
    from datetime import datetime

    try:
        when = None if body.date is None else datetime.fromisoformat(body.date)
    except ValueError:
        raise InputError(f"date {body.date!r}: not an ISO 8601 date") from None
    made = amend_run(
        request.app.state.engine,
        run_id,
        {
            "performed_at": when,
            "operator_note": body.note,
            "temperature_c": body.temperature,
            "operator": body.operator,
        },
        reason=body.why,
        by=user.username,
        category=category,
    )
    return [a.to_dict() for a in made]


@router.get("/audit")
def audit_log(
    request: Request,
    _: Viewer,
    action: Annotated[str | None, Query(max_length=50)] = None,
    limit: Annotated[int, Query(ge=1, le=1000)] = 200,
) -> list[dict]:
    """The latest audit rows, newest first."""
    with Session(request.app.state.engine) as session:
        return audit_entries(session, limit=limit, action=action)
