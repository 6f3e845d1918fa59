"""Every mutating route writes exactly one audit row (SQLite and PostgreSQL); the audit log
refuses UPDATE and DELETE (see also tests/history/test_amendments.py)."""

from __future__ import annotations

import base64
import json
import re

import pytest
from sqlalchemy import text
from sqlalchemy.exc import DBAPIError
from webtools import MACHINE, PASSWORD, app_routes, calibration, csrf_of

from mtmetrology.errors import InputError


def _token(client) -> str:
    page = client.post("/tokens", data={"csrf": csrf_of(client, "/tokens"), "name": "t"})
    return re.search(r"(mtm_[\w-]+)", page.text).group(1)


def _cases(lab, client, headers):
    """One valid request per mutating route: (method, path) -> callable."""
    csrf = csrf_of(client, "/machines")
    upload = json.dumps(calibration([3.0] * 13)).encode()
    return {
        ("POST", "/login"): lambda: _login(lab),
        ("POST", "/logout"): lambda: _logout(lab),
        ("POST", "/machines/five-axis-wcbxfzyst/limits"): lambda: client.post(
            f"/machines/{MACHINE.name}/limits",
            data={"csrf": csrf, "parameter": "E_X0C", "mpe": "5", "reliability": "0.9"},
        ),
        ("POST", "/runs/calibration/1/amend"): lambda: client.post(
            "/runs/calibration/1/amend", data={"csrf": csrf, "operator": "ada", "why": "w"}
        ),
        ("POST", "/upload"): lambda: client.post(
            "/upload",
            data={"csrf": csrf, "note": "n"},
            files={"result": ("cal.json", upload, "application/json")},
        ),
        ("POST", "/users"): lambda: client.post(
            "/users",
            data={"csrf": csrf, "username": "new", "password": PASSWORD, "role": "viewer"},
        ),
        ("POST", "/users/1"): lambda: client.post(
            "/users/1", data={"csrf": csrf, "role": "engineer", "active": "yes"}
        ),
        ("POST", "/tokens"): lambda: client.post("/tokens", data={"csrf": csrf, "name": "x"}),
        ("POST", "/settings"): lambda: client.post(
            "/settings",
            data={
                "csrf": csrf,
                "laboratory": "L",
                "email": "l@x.org",
                "country": "DE",
                "due_soon_days": "10",
            },
        ),
        ("POST", "/api/v1/runs"): lambda: client.post(
            "/api/v1/runs",
            headers=headers,
            json={
                "filename": "c.json",
                "content_base64": base64.b64encode(
                    json.dumps(calibration([4.0] * 13)).encode()
                ).decode(),
            },
        ),
        ("POST", "/api/v1/runs/calibration/1/amendments"): lambda: client.post(
            "/api/v1/runs/calibration/1/amendments",
            headers=headers,
            json={"why": "typo", "note": "corrected"},
        ),
        # last: it revokes the token the API cases use
        ("POST", "/tokens/1/revoke"): lambda: client.post("/tokens/1/revoke", data={"csrf": csrf}),
    }


def _login(lab):
    c = lab.client()
    return c.post("/login", data={"csrf": csrf_of(c), "username": "viewer", "password": PASSWORD})


def _logout(lab):
    c = lab.client("viewer")
    return c.post("/logout", data={"csrf": csrf_of(c, "/machines")})


def test_every_mutating_route_writes_one_audit_row(lab):
    client = lab.client("admin")
    headers = {"Authorization": f"Bearer {_token(client)}"}
    cases = _cases(lab, client, headers)
    mutating = {(m, p) for p, m in app_routes(lab.app) if m != "GET"}
    assert mutating == set(cases)  # a new mutating route needs its case here
    for key, request in cases.items():
        # the logout case logs in first: that login writes its own row
        before = lab.audit_count() + (key == ("POST", "/logout"))
        response = request()
        assert response.status_code in (200, 201, 303), (key, response.status_code, response.text)
        assert lab.audit_count() == before + 1, key


def test_a_refused_request_writes_no_audit_row(sqlite_lab):
    viewer = sqlite_lab.client("viewer")
    before = sqlite_lab.audit_count()
    upload = json.dumps(calibration([3.0] * 13)).encode()
    response = viewer.post(
        "/upload",
        data={"csrf": csrf_of(viewer, "/machines")},
        files={"result": ("cal.json", upload, "application/json")},
    )
    assert response.status_code == 403
    assert sqlite_lab.audit_count() == before


@pytest.mark.parametrize("statement", ["UPDATE audit_log SET actor = 'x'", "DELETE FROM audit_log"])
def test_the_audit_log_refuses_update_and_delete(lab, statement):
    before = lab.audit_count()
    assert before > 0
    with pytest.raises((DBAPIError, InputError), match="append-only"), lab.engine.begin() as c:
        c.execute(text(statement))
    assert lab.audit_count() == before
