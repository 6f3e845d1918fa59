"""Fixtures: every history test runs against SQLite and against a real PostgreSQL server.

The server is the Debian package ``postgresql`` (``/usr/lib/postgresql/*/bin``): a cluster
made by ``initdb`` in a temporary directory, started by ``pg_ctl`` on a free loopback port
(as the user ``nobody`` when the tests run as root: the server refuses root), one fresh
database per test, stopped at the end of the session. Without the binaries the
PostgreSQL cases skip with that reason, unless ``MTM_REQUIRE_POSTGRES=1`` (CI), where they
fail.
"""

from __future__ import annotations

import glob
import importlib.util
import os
import shutil
import socket
import subprocess
import tempfile
import uuid
from pathlib import Path

import numpy as np
import pytest

from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

MACHINE = Machine.load("five-axis-wcbxfzyst")


def _server_binaries() -> Path | None:
    found = sorted(glob.glob("/usr/lib/postgresql/*/bin/pg_ctl"))
    if found:
        return Path(found[-1]).parent
    on_path = shutil.which("pg_ctl")
    return Path(on_path).parent if on_path else None


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture(scope="session")
def postgres_server():
    """``postgresql://postgres@127.0.0.1:PORT`` of a server started for the session."""
    binaries = _server_binaries()
    reason = None
    if binaries is None:
        reason = "PostgreSQL server binaries not found (Debian package postgresql)"
    elif importlib.util.find_spec("psycopg") is None:
        reason = "the PostgreSQL driver psycopg is not installed (the test extra has it)"
    if reason is not None:
        if os.environ.get("MTM_REQUIRE_POSTGRES") == "1":
            pytest.fail(f"{reason}, and MTM_REQUIRE_POSTGRES=1")
        pytest.skip(reason)
    root = Path(tempfile.mkdtemp(prefix="mtm-pg-"))
    prefix: list[str] = []
    if os.geteuid() == 0:
        os.chmod(root, 0o755)
        shutil.chown(root, "nobody", "nogroup")
        prefix = ["runuser", "-u", "nobody", "--"]
    data, port = root / "data", _free_port()
    run = dict(check=True, capture_output=True, cwd=root)
    subprocess.run(
        [
            *prefix,
            str(binaries / "initdb"),
            "-D",
            str(data),
            "-U",
            "postgres",
            "-A",
            "trust",
            "-E",
            "UTF8",
            "--no-sync",
        ],
        **run,
    )
    options = f"-p {port} -h 127.0.0.1 -k {root} -c fsync=off"
    subprocess.run(
        [
            *prefix,
            str(binaries / "pg_ctl"),
            "-D",
            str(data),
            "-o",
            options,
            "-l",
            str(root / "server.log"),
            "-w",
            "-t",
            "60",
            "start",
        ],
        **run,
    )
    try:
        yield f"postgresql://postgres@127.0.0.1:{port}"
    finally:
        subprocess.run(
            [*prefix, str(binaries / "pg_ctl"), "-D", str(data), "-m", "immediate", "stop"],
            capture_output=True,
            cwd=root,
        )
        shutil.rmtree(root, ignore_errors=True)


@pytest.fixture(params=["sqlite", "postgresql"])
def history_url(request, tmp_path) -> str:
    """A URL of an empty history database on each backend."""
    if request.param == "sqlite":
        return f"sqlite:///{tmp_path / 'history.sqlite'}"
    import psycopg

    server = request.getfixturevalue("postgres_server")
    name = f"h{uuid.uuid4().hex[:12]}"
    with psycopg.connect(f"{server}/postgres", autocommit=True) as connection:
        connection.execute(f"CREATE DATABASE {name}")
    return f"{server}/{name}"


def calibration(values_um, *, u=0.5, machine=MACHINE, model="13") -> dict:
    """A parameter-set document of ``machine`` with values (customary units) and u."""
    values = np.asarray(values_um, dtype=float) * machine.parameter_scales
    pset = ParameterSet(
        machine.parameter_names,
        values,
        machine.parameter_units,
        np.diag((machine.parameter_scales * u) ** 2),
        machine=machine.name,
        model=model,
    )
    return pset.to_document()


@pytest.fixture
def make_calibration():
    """:func:`calibration`, for the test modules."""
    return calibration
