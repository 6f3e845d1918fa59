"""Fixtures of the web application's tests: the application over a history on SQLite and on
the real PostgreSQL server of the history tests (their fixtures, reused), with three users
and a few calibrations; a logged-in test client per role."""

from __future__ import annotations

import importlib.util
import re
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest

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


@pytest.fixture(autouse=True)
def cheap_password_hashes(monkeypatch):
    """Argon2id with small costs in the tests (the hashes state their own parameters, so
    verification is unchanged; the application's defaults are RFC 9106's)."""
    from argon2 import PasswordHasher

    from mtmetrology.web import security

    monkeypatch.setattr(
        security, "_HASHER", PasswordHasher(time_cost=1, memory_cost=1024, parallelism=1)
    )


@pytest.fixture
def lab(history_url) -> Lab:
    """The application over a filled history, on SQLite and on PostgreSQL."""
    return Lab(history_url)


@pytest.fixture
def sqlite_lab(tmp_path) -> Lab:
    """The application over a filled SQLite history."""
    return Lab(f"sqlite:///{tmp_path / 'history.sqlite'}")
