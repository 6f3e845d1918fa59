"""Helpers of the web application's tests (a module name of its own: the suite's
``conftest`` modules share one name): the application over a filled history, logged-in
clients, the history tests' PostgreSQL fixtures (reused) and the application's routes."""

from __future__ import annotations

import importlib.util
import re
from datetime import UTC, datetime, timedelta
from pathlib import Path

from fastapi.routing import APIRoute

HERE = Path(__file__).resolve().parent
PASSWORD = "correct-horse-battery"


def _load(name: str, path: Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_history = _load("mtm_history_conftest", HERE.parent / "history" / "conftest.py")
postgres_server = _history.postgres_server
history_url = _history.history_url
calibration = _history.calibration
MACHINE = _history.MACHINE


class Lab:
    """The application under test and what it was filled with."""

    def __init__(self, url: str) -> None:
        from mtmetrology.history import add_result, open_history
        from mtmetrology.web import create_app
        from mtmetrology.web.security import create_user

        self.url = url
        self.app = create_app(url, secret="s" * 40, max_upload_bytes=256 * 1024)
        self.engine = self.app.state.engine
        self.users = {
            role: create_user(self.engine, role, PASSWORD, role, by="test")
            for role in ("viewer", "engineer", "admin")
        }
        start = datetime(2026, 1, 1, tzinfo=UTC)
        self.runs = [
            add_result(
                open_history(url),
                calibration([0.1 * k + 0.07 * (-1) ** k] * 13),
                MACHINE,
                performed_at=start + timedelta(days=30 * k),
                note=f"run {k}",
                by="test",
            ).id
            for k in range(6)
        ]

    def client(self, role: str | None = None):
        """A test client, logged in as ``role`` (None: anonymous)."""
        from fastapi.testclient import TestClient

        client = TestClient(self.app, follow_redirects=False)
        if role is not None:
            response = login(client, role, PASSWORD)
            assert response.status_code == 303, response.text
        return client

    def table_counts(self) -> dict[str, int]:
        """Rows per table (to see that a request changed nothing)."""
        from sqlalchemy import inspect, text

        with self.engine.connect() as c:
            names = inspect(c).get_table_names()
            return {n: c.execute(text(f'SELECT count(*) FROM "{n}"')).scalar() for n in names}

    def audit_count(self) -> int:
        return self.table_counts()["audit_log"]


def csrf_of(client, path: str = "/login") -> str:
    """The CSRF token of the client's session, read from a page's form."""
    page = client.get(path)
    return re.search(r'name="csrf" value="([^"]+)"', page.text).group(1)


def login(client, username: str, password: str):
    return client.post(
        "/login",
        data={"csrf": csrf_of(client), "username": username, "password": password},
    )


#: Path parameter values that name existing things (a refusal must not be a 404).
PATH_VALUES = {
    "name": "five-axis-wcbxfzyst",
    "category": "calibration",
    "run_id": "1",
    "user_id": "1",
    "token_id": "1",
}


def _flat(routes):
    for route in routes:
        if hasattr(route, "original_router"):  # FastAPI >= 0.16x keeps included routers
            yield from _flat(route.original_router.routes)
        elif isinstance(route, APIRoute):
            yield route


def app_routes(app) -> list[tuple[str, str]]:
    """Every (path, method) of the application's routes, path parameters filled in."""
    out = []
    for route in _flat(app.routes):
        path = re.sub(r"\{(\w+)\}", lambda m: PATH_VALUES[m.group(1)], route.path)
        out += [(path, method) for method in sorted(route.methods - {"HEAD"})]
    return out
