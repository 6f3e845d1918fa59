"""Fixtures of the web application's tests: the application over a history on SQLite and on
the real PostgreSQL server of the history tests (their fixtures, reused), with three users
and a few calibrations."""

from __future__ import annotations

import pytest
from webtools import Lab, history_url, postgres_server  # noqa: F401 (fixtures)


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
def lab(history_url) -> Lab:  # noqa: F811 (the imported fixture, requested)
    """The application over a filled history, on SQLite and on PostgreSQL."""
    return Lab(history_url)


@pytest.fixture
def sqlite_lab(tmp_path) -> Lab:
    """The application over a filled SQLite history."""
    return Lab(f"sqlite:///{tmp_path / 'history.sqlite'}")
