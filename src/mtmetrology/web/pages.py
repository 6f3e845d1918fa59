"""The server-rendered pages (Jinja2, autoescaped; htmx for the machines filter and the
chart of the chosen parameter).

Every route asks for a logged-in user first (:func:`user_of`: 401 → the login page), every
POST then checks the form's CSRF token (:func:`checked_form`) and the role, and writes one
audit row through the library function it calls.
"""

from __future__ import annotations

import json
from datetime import datetime
from typing import Annotated, Literal

import numpy as np
from fastapi import APIRouter, Query, Request
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from markupsafe import Markup

from mtmetrology.errors import InputError
from mtmetrology.history.amendments import amend_run, original_values, show_amended
from mtmetrology.history.analysis import long_term_covariance
from mtmetrology.history.audit import ROLES, audit_entries
from mtmetrology.history.records import list_runs
from mtmetrology.history.settings import (
    lab_settings,
    set_lab_settings,
    set_machine_limit,
)
from mtmetrology.web import security
from mtmetrology.web.figures import certificate_xml, run_report
from mtmetrology.web.security import DOCUMENT_CSP, Refused
from mtmetrology.web.upload import upload_result

router = APIRouter()
Category = Literal["calibration", "task", "verification"]
SORTS = ("name", "status", "last_calibration", "due_date", "runs")
PAGE_RUNS = 50


def user_of(request: Request, role: str = "viewer"):
    """The session's active user with at least ``role``; Refused (401/403) otherwise."""
    user = security.session_user(request.app.state.engine, request.session.get("uid"))
    if user is None:
        raise Refused(401, "log in first")
    if not security.may(user, role):
        raise Refused(403, f"{user.username} ({user.role}): this needs the {role} role")
    return user


async def checked_form(request: Request, role: str = "viewer"):
    """The user and the posted form, after the session, the CSRF token and the role."""
    user_of(request)
    form = await request.form(max_files=1, max_fields=20, max_part_size=64 * 1024)
    if not security.csrf_valid(request.session, form.get("csrf")):
        raise Refused(403, "the form's CSRF token is missing or wrong: reload the page")
    return user_of(request, role), form


def csrf_of(request: Request) -> str:
    """The session's CSRF token (made on first use)."""
    if "csrf" not in request.session:
        request.session["csrf"] = security.new_csrf()
    return request.session["csrf"]


def render(request: Request, name: str, user, code: int = 200, **context) -> HTMLResponse:
    """A page of ``templates/`` with the user and the CSRF token."""
    return request.app.state.templates.TemplateResponse(
        request, name, {"user": user, "csrf": csrf_of(request), **context}, status_code=code
    )


def _back(url: str) -> RedirectResponse:
    return RedirectResponse(url, status_code=303)


# -- login -------------------------------------------------------------------------------
@router.get("/login", response_class=HTMLResponse)
def login_page(request: Request):
    return render(request, "login.html.j2", None, message=None)


@router.post("/login")
async def login(request: Request):
    form = await request.form(max_files=0, max_fields=5, max_part_size=4096)
    if not security.csrf_valid(request.session, form.get("csrf")):
        raise Refused(403, "the form's CSRF token is missing or wrong: reload the page")
    client = request.client.host if request.client else "?"
    user, outcome = security.authenticate(
        request.app.state.engine,
        str(form.get("username", "")),
        str(form.get("password", "")),
        client,
    )
    if user is None:
        message = (
            f"too many wrong passwords: this login is locked for "
            f"{security.LOCK_SECONDS // 60} minutes"
            if outcome == "locked"
            else "wrong user name or password"
        )
        return render(
            request, "login.html.j2", None, 429 if outcome == "locked" else 401, message=message
        )
    request.session.clear()
    request.session.update(uid=user.id, csrf=security.new_csrf())
    return _back("/machines")


@router.post("/logout")
async def logout(request: Request):
    from sqlalchemy.orm import Session

    from mtmetrology.history.audit import audit
    from mtmetrology.history.database import writer

    user, _ = await checked_form(request)
    with Session(writer(request.app.state.engine)) as session, session.begin():
        audit(session, user.username, "logout", f"user {user.username}")
    request.session.clear()
    return _back("/login")


# -- machines ----------------------------------------------------------------------------
@router.get("/", response_class=HTMLResponse)
def home(request: Request):
    user_of(request)
    return _back("/machines")


@router.get("/machines", response_class=HTMLResponse)
def machines(
    request: Request,
    q: Annotated[str, Query(max_length=100)] = "",
    status: Annotated[str, Query(max_length=30)] = "",
    sort: Annotated[str, Query(max_length=30)] = "name",
    order: Annotated[str, Query(max_length=4)] = "asc",
):
    user = user_of(request)
    rows = [
        m
        for m in request.app.state.lab.overview()
        if q.lower() in m.name.lower() and (not status or m.status == status)
    ]
    key = sort if sort in SORTS else "name"
    rows.sort(key=lambda m: _sort_key(m, key), reverse=order == "desc")
    template = "machines_rows.html.j2" if request.headers.get("HX-Request") else "machines.html.j2"
    return render(
        request,
        template,
        user,
        machines=rows,
        q=q,
        status=status,
        sort=key,
        order=order,
        statuses=("ok", "due soon", "overdue", "out of control"),
        settings=lab_settings(request.app.state.engine),
    )


def _sort_key(m, key: str):
    value = getattr(m, key)
    if key == "status":
        return ("ok", "due soon", "overdue", "out of control").index(value)
    if isinstance(value, datetime):
        return value.timestamp()
    return (value is None, value if value is not None else 0)


@router.get("/machines/{name}", response_class=HTMLResponse)
def machine_page(
    request: Request,
    name: str,
    parameter: Annotated[str | None, Query(max_length=50)] = None,
    page: Annotated[int, Query(ge=1, le=100000)] = 1,
):
    user = user_of(request)
    lab = request.app.state.lab
    overview = lab.machine(name)
    # every part below is computed once per history version (cache misses only): a warm
    # page only looks them up
    rows = lab.cached(
        ("rows", name), lambda: {r["parameter"]: r for r in lab.parameter_table(name)}
    )
    chosen = parameter if parameter in rows else next(iter(rows), None)
    newest_first = lab.cached(("runs", name), lambda: list_runs(lab.engine, machine=name)[::-1])
    return render(
        request,
        "machine.html.j2",
        user,
        m=overview,
        chart=None
        if chosen is None
        else lab.cached(
            ("chart", name, chosen), lambda: _macros(request).chart(overview, rows[chosen])
        ),
        runs=lab.cached(
            ("runs-page", name, page),
            lambda: _macros(request).runs_rows(
                newest_first[(page - 1) * PAGE_RUNS : page * PAGE_RUNS], "calibration"
            ),
        ),
        page=page,
        pages=max(1, -(-len(newest_first) // PAGE_RUNS)),
        tables=lab.cached(("tables", name), lambda: _tables(request, name)),
    )


def _macros(request: Request):
    return request.app.state.templates.get_template("machine_tables.html.j2").module


def _tables(request: Request, name: str) -> dict[str, Markup]:
    """The machine page's parts that depend on the history only, rendered (autoescaped)
    once per history version: the parameter table, the MPE form's options, the covariance
    and the task and verification results. With the chart and the page of runs, also
    cached, these rows were nearly all of a warm page's time (cProfile, 10⁴ runs of the
    84-coefficient model: 16 ms before any was cached, 1 ms of rendering with them)."""
    lab = request.app.state.lab
    macros = _macros(request)
    m = {"name": name}
    table = lab.parameter_table(name)
    others = {c: list_runs(lab.engine, machine=name, category=c) for c in ("task", "verification")}
    return {
        "parameters": macros.parameters(m, table),
        "options": macros.parameter_options(table),
        "covariance": macros.covariance_section(m, _covariance(lab.engine, name)),
        "others": macros.others_section(others),
    }


def _covariance(engine, name: str) -> list[dict] | None:
    """Per parameter the long-term standard deviation (customary unit)."""
    try:
        pset = long_term_covariance(engine, name)
    except InputError:
        return None  # fewer than two calibrations
    std = np.sqrt(np.diag(pset.covariance)) / pset.scales()
    return [
        {"name": n, "unit": u, "std": float(s)}
        for n, u, s in zip(pset.names, pset.units, std, strict=True)
    ]


@router.get("/machines/{name}/chart", response_class=HTMLResponse)
def chart(request: Request, name: str, parameter: Annotated[str, Query(max_length=50)]):
    user = user_of(request)
    row = next(
        (r for r in request.app.state.lab.parameter_table(name) if r["parameter"] == parameter),
        None,
    )
    if row is None:
        raise InputError(f"parameter {parameter!r}: not a parameter of {name!r}")
    return render(request, "chart.html.j2", user, m={"name": name}, row=row)


@router.get("/machines/{name}/trend.svg")
def trend_svg(request: Request, name: str, parameter: Annotated[str, Query(max_length=50)]):
    user_of(request)
    svg = request.app.state.lab.trend_svg(name, parameter)
    return Response(
        svg,
        media_type="image/svg+xml",
        headers={"Content-Security-Policy": DOCUMENT_CSP, "X-Frame-Options": "SAMEORIGIN"},
    )


@router.get("/machines/{name}/covariance.json")
def covariance_json(request: Request, name: str):
    user_of(request)
    pset = long_term_covariance(request.app.state.engine, name)
    return _download(
        json.dumps(pset.to_document(), indent=2), f"{name}-covariance.json", "application/json"
    )


@router.post("/machines/{name}/limits")
async def set_limit(request: Request, name: str):
    user, form = await checked_form(request, "admin")
    try:
        mpe, reliability = float(form.get("mpe", "")), float(form.get("reliability", "0.95"))
    except ValueError:
        raise InputError("mpe and reliability: numbers") from None
    set_machine_limit(
        request.app.state.engine,
        name,
        str(form.get("parameter", "")),
        mpe,
        reliability,
        by=user.username,
    )
    return _back(f"/machines/{name}")


# -- runs --------------------------------------------------------------------------------
@router.get("/runs/{category}/{run_id}", response_class=HTMLResponse)
def run_page(request: Request, category: Category, run_id: int):
    user = user_of(request)
    record, amendments = show_amended(request.app.state.engine, run_id, category)
    return render(
        request,
        "run.html.j2",
        user,
        r=record,
        amendments=amendments,
        originals=original_values(amendments),
        may_amend=security.may(user, "engineer"),
    )


@router.get("/runs/{category}/{run_id}/report.html")
def run_report_page(request: Request, category: Category, run_id: int):
    user_of(request)
    lab = request.app.state.lab

    def build():
        record, amendments = show_amended(lab.engine, run_id, category)
        return run_report(record, amendments)

    return HTMLResponse(
        lab.cached(("report", category, run_id), build),
        headers={"Content-Security-Policy": DOCUMENT_CSP, "X-Frame-Options": "SAMEORIGIN"},
    )


@router.get("/runs/{category}/{run_id}/result.json")
def run_result(request: Request, category: Category, run_id: int):
    user_of(request)
    record, _ = show_amended(request.app.state.engine, run_id, category)
    return _download(
        json.dumps(record.result, indent=2), f"{category}-{run_id}.json", "application/json"
    )


@router.get("/runs/{category}/{run_id}/certificate.xml")
def run_certificate(request: Request, category: Category, run_id: int):
    user_of(request)
    engine = request.app.state.engine
    record, _ = show_amended(engine, run_id, category)
    xml = certificate_xml(record, lab_settings(engine))
    return _download(xml, f"{record.machine}-calibration-{run_id}.xml", "application/xml")


def _download(content, filename: str, media_type: str) -> Response:
    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in filename)
    return Response(
        content,
        media_type=media_type,
        headers={"Content-Disposition": f'attachment; filename="{safe}"'},
    )


@router.post("/runs/{category}/{run_id}/amend")
async def amend(request: Request, category: Category, run_id: int):
    user, form = await checked_form(request, "engineer")
    date = str(form.get("date", "")).strip()
    temperature = str(form.get("temperature", "")).strip()
    try:
        changes = {
            "performed_at": datetime.fromisoformat(date) if date else None,
            "operator_note": str(form.get("note", "")).strip() or None,
            "temperature_c": float(temperature) if temperature else None,
            "operator": str(form.get("operator", "")).strip() or None,
        }
    except ValueError as err:
        raise InputError(f"amendment: {err}") from None
    amend_run(
        request.app.state.engine,
        run_id,
        changes,
        reason=str(form.get("why", "")),
        by=user.username,
        category=category,
    )
    return _back(f"/runs/{category}/{run_id}")


# -- upload ------------------------------------------------------------------------------
@router.get("/upload", response_class=HTMLResponse)
def upload_page(request: Request):
    return render(request, "upload.html.j2", user_of(request, "engineer"), message=None)


@router.post("/upload")
async def upload(request: Request):
    user_of(request)
    form = await request.form(
        max_files=1, max_fields=10, max_part_size=request.app.state.max_upload
    )
    if not security.csrf_valid(request.session, form.get("csrf")):
        raise Refused(403, "the form's CSRF token is missing or wrong: reload the page")
    user = user_of(request, "engineer")
    file = form.get("result")
    if file is None or isinstance(file, str):
        raise InputError("upload: choose a result JSON file")
    data = await file.read()
    record = upload_result(
        request.app.state.engine,
        data,
        file.filename or "upload.json",
        user=user,
        note=str(form.get("note", "")).strip() or None,
        date=str(form.get("date", "")).strip() or None,
    )
    return _back(f"/runs/{record.category}/{record.id}")


# -- administration ----------------------------------------------------------------------
@router.get("/audit", response_class=HTMLResponse)
def audit_page(request: Request, action: Annotated[str | None, Query(max_length=50)] = None):
    from sqlalchemy.orm import Session

    user = user_of(request)
    with Session(request.app.state.engine) as session:
        entries = audit_entries(session, action=action or None)
    return render(request, "audit.html.j2", user, entries=entries, action=action or "")


@router.get("/users", response_class=HTMLResponse)
def users_page(request: Request):
    user = user_of(request, "admin")
    return render(
        request,
        "users.html.j2",
        user,
        users=security.list_users(request.app.state.engine),
        roles=ROLES,
    )


@router.post("/users")
async def create_user(request: Request):
    user, form = await checked_form(request, "admin")
    security.create_user(
        request.app.state.engine,
        str(form.get("username", "")),
        str(form.get("password", "")),
        str(form.get("role", "")),
        by=user.username,
    )
    return _back("/users")


@router.post("/users/{user_id}")
async def change_user(request: Request, user_id: int):
    user, form = await checked_form(request, "admin")
    active = form.get("active")
    security.set_user(
        request.app.state.engine,
        user_id,
        role=form.get("role") or None,
        active=None if active is None else active == "yes",
        by=user.username,
    )
    return _back("/users")


@router.get("/tokens", response_class=HTMLResponse)
def tokens_page(request: Request):
    user = user_of(request)
    return render(
        request,
        "tokens.html.j2",
        user,
        secret=None,
        tokens=security.list_tokens(request.app.state.engine, user.id),
    )


@router.post("/tokens")
async def create_token(request: Request):
    user, form = await checked_form(request)
    engine = request.app.state.engine
    secret = security.create_token(engine, user.id, str(form.get("name", "")), by=user.username)
    return render(
        request, "tokens.html.j2", user, secret=secret, tokens=security.list_tokens(engine, user.id)
    )


@router.post("/tokens/{token_id}/revoke")
async def revoke_token(request: Request, token_id: int):
    user, _ = await checked_form(request)
    security.revoke_token(request.app.state.engine, token_id, user_id=user.id, by=user.username)
    return _back("/tokens")


@router.get("/settings", response_class=HTMLResponse)
def settings_page(request: Request):
    user = user_of(request, "admin")
    return render(
        request, "settings.html.j2", user, settings=lab_settings(request.app.state.engine)
    )


@router.post("/settings")
async def change_settings(request: Request):
    user, form = await checked_form(request, "admin")
    try:
        days = int(str(form.get("due_soon_days", "30")))
    except ValueError:
        raise InputError("due_soon_days: a whole number of days") from None
    set_lab_settings(
        request.app.state.engine,
        {
            "laboratory": str(form.get("laboratory", "")).strip(),
            "email": str(form.get("email", "")).strip(),
            "country": str(form.get("country", "")).strip(),
            "responsible_person": str(form.get("responsible_person", "")).strip(),
            "manufacturer": str(form.get("manufacturer", "")).strip(),
            "due_soon_days": days,
        },
        by=user.username,
    )
    return _back("/settings")
