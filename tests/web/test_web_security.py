"""Security of the web application (issue 34), on SQLite and PostgreSQL."""

from __future__ import annotations

import json
import re

import itsdangerous
import pytest
from webtools import PASSWORD, app_routes, csrf_of, login

from mtmetrology.web.security import LOCK_AFTER

OPEN = {("/login", "GET"), ("/login", "POST")}


def test_every_route_refuses_an_anonymous_request(lab):
    routes = app_routes(lab.app)
    assert len(routes) >= 30  # pages and API: the test covers them all
    client = lab.client()
    before = lab.table_counts()
    for path, method in routes:
        if (path, method) in OPEN:
            continue
        response = client.request(method, path, params={"parameter": "E_X0C"})
        if path.startswith("/api/"):
            assert response.status_code == 401, (method, path, response.status_code)
            assert response.headers["www-authenticate"] == "Bearer"
        else:
            assert response.status_code == 303, (method, path, response.status_code)
            assert response.headers["location"] == "/login", (method, path)
        assert "five-axis" not in response.text or path.startswith("/login")
    # a cookie of another application's key is no session either
    forged = itsdangerous.TimestampSigner("another key").sign(b"eyJ1aWQiOiAzfQ==")
    client.cookies.set("mtm_session", forged.decode())
    assert client.get("/machines").status_code == 303
    after = lab.table_counts()
    assert after == before


def test_the_route_check_can_fail(lab):
    """A logged-in client is let through: the refusals above are the session's doing."""
    client = lab.client("viewer")
    assert client.get("/machines").status_code == 200
    assert client.get("/runs/calibration/1/result.json").status_code == 200


def test_a_form_without_its_csrf_token_is_refused(lab):
    client = lab.client("admin")
    form = {"laboratory": "Evil", "email": "e@x.org", "country": "FR", "due_soon_days": "3"}
    for token in (None, "", "forged-token"):
        data = form if token is None else {**form, "csrf": token}
        response = client.post("/settings", data=data)
        assert response.status_code == 403
    assert "Evil" not in client.get("/settings").text
    ok = client.post("/settings", data={**form, "csrf": csrf_of(client, "/settings")})
    assert ok.status_code == 303 and "Evil" in client.get("/settings").text
    # the login form too (login CSRF)
    anonymous = lab.client()
    bare = anonymous.post("/login", data={"username": "admin", "password": PASSWORD})
    assert bare.status_code == 403


def test_a_script_in_a_note_is_shown_escaped(lab):
    client = lab.client("engineer")
    note = '<script>alert("x")</script><img src=x onerror=alert(1)>'
    response = client.post(
        "/runs/calibration/1/amend",
        data={"csrf": csrf_of(client, "/runs/calibration/1"), "note": note, "why": note},
    )
    assert response.status_code == 303
    for page in ("/runs/calibration/1", "/machines/five-axis-wcbxfzyst", "/audit"):
        text = lab.client("viewer").get(page).text
        assert "<script>alert" not in text and "<img src=x" not in text, page
        # shown, as text: HTML-escaped, or in the audit's JSON detail with \u003c escapes
        assert "&lt;script&gt;alert(" in text or "\\u003cscript\\u003e" in text, page


@pytest.mark.parametrize(
    "path",
    [
        "/static/../pyproject.toml",
        "/static/%2e%2e/%2e%2e/%2e%2e/%2e%2e/pyproject.toml",
        "/static/..%2f..%2f..%2f..%2fpyproject.toml",
        "/runs/calibration/..%2f..%2fpyproject.toml/result.json",
        "/runs/..%2f..%2fetc/1/result.json",
        "/runs/calibration/1%2f..%2f..%2f2/result.json",
        "/machines/..%2f..%2f..%2fetc%2fpasswd/covariance.json",
    ],
)
def test_a_path_traversal_download_is_refused(sqlite_lab, path):
    response = sqlite_lab.client("admin").get(path)
    assert response.status_code in (400, 404, 422), response.status_code
    assert "[project]" not in response.text and "root:" not in response.text


INJECTIONS = ["' OR '1'='1", "1; DROP TABLE users; --", '" OR ""="', "%' --", "1) OR (1=1"]
QUERIES = [
    ("/machines", ("q", "status", "sort", "order")),
    ("/machines/five-axis-wcbxfzyst", ("parameter",)),
    ("/machines/five-axis-wcbxfzyst/chart", ("parameter",)),
    ("/machines/five-axis-wcbxfzyst/trend.svg", ("parameter",)),
    ("/audit", ("action",)),
    ("/api/v1/machines/five-axis-wcbxfzyst/trend", ("parameter",)),
    ("/api/v1/audit", ("action",)),
]


def test_sql_metacharacters_in_every_query_parameter_change_nothing(lab):
    client = lab.client("admin")
    token = client.post("/tokens", data={"csrf": csrf_of(client, "/tokens"), "name": "t"})
    headers = {"Authorization": "Bearer " + re.search(r"(mtm_[\w-]+)", token.text).group(1)}
    before = lab.table_counts()
    for path, names in QUERIES:
        for name in names:
            for value in INJECTIONS:
                response = client.get(path, params={name: value}, headers=headers)
                assert response.status_code in (200, 400, 404, 422), (path, name, value)
                if path == "/machines" and name == "q":
                    assert 'data-machine="' not in response.text  # no machine matched
                if path == "/api/v1/audit":
                    assert response.json() == []  # no action of that name
    assert lab.table_counts() == before


def test_a_revoked_token_is_refused(lab):
    client = lab.client("viewer")
    page = client.post("/tokens", data={"csrf": csrf_of(client, "/tokens"), "name": "ci"})
    secret = re.search(r"(mtm_[\w-]+)", page.text).group(1)
    api = lab.client()
    headers = {"Authorization": f"Bearer {secret}"}
    assert api.get("/api/v1/machines", headers=headers).status_code == 200
    token_id = re.search(r"/tokens/(\d+)/revoke", page.text).group(1)
    revoked = client.post(f"/tokens/{token_id}/revoke", data={"csrf": csrf_of(client, "/tokens")})
    assert revoked.status_code == 303
    assert api.get("/api/v1/machines", headers=headers).status_code == 401
    # another user cannot revoke (or see) someone else's token
    other = lab.client("engineer")
    assert (
        other.post(
            f"/tokens/{token_id}/revoke", data={"csrf": csrf_of(other, "/tokens")}
        ).status_code
        == 400
    )


def test_ten_wrong_passwords_lock_the_login(lab):
    client = lab.client()
    for _ in range(LOCK_AFTER):
        assert login(client, "engineer", "wrong password!").status_code == 401
    locked = login(client, "engineer", PASSWORD)
    assert locked.status_code == 429
    assert "uid" not in json.dumps(dict(client.cookies))
    assert client.get("/machines").status_code == 303
    # the lock is per user name: another user logs in
    assert login(lab.client(), "viewer", PASSWORD).status_code == 303


def test_nine_wrong_passwords_do_not_lock(sqlite_lab):
    client = sqlite_lab.client()
    for _ in range(LOCK_AFTER - 1):
        assert login(client, "engineer", "wrong password!").status_code == 401
    assert login(client, "engineer", PASSWORD).status_code == 303


def test_security_headers(sqlite_lab):
    client = sqlite_lab.client("viewer")
    for path in ("/login", "/machines", "/runs/calibration/1"):
        headers = client.get(path).headers
        csp = dict(p.strip().split(" ", 1) for p in headers["content-security-policy"].split(";"))
        assert csp["script-src"] == "'self'" and csp["style-src"] == "'self'"
        assert csp["frame-ancestors"] == "'none'"
        assert headers["x-frame-options"] == "DENY"
        assert headers["referrer-policy"] == "no-referrer"
    for path in ("/machines", "/runs/calibration/1", "/login"):
        assert "<script>" not in client.get(path).text  # no inline script in any page
    report = client.get("/runs/calibration/1/report.html").headers
    assert "script" not in report["content-security-policy"]


def test_sessions_expire(sqlite_lab, monkeypatch):
    client = sqlite_lab.client("viewer")
    assert client.get("/machines").status_code == 200
    real = itsdangerous.TimestampSigner.get_timestamp
    monkeypatch.setattr(
        itsdangerous.TimestampSigner, "get_timestamp", lambda self: real(self) + 9 * 3600
    )
    assert client.get("/machines").status_code == 303


def test_uploads_are_size_limited(sqlite_lab):
    client = sqlite_lab.client("admin")
    big = b'{"kind": "parameter-set", "pad": "' + b"x" * 300_000 + b'"}'
    before = sqlite_lab.table_counts()
    response = client.post(
        "/upload",
        data={"csrf": csrf_of(client, "/upload")},
        files={"result": ("big.json", big, "application/json")},
    )
    assert response.status_code == 413
    assert sqlite_lab.table_counts() == before
