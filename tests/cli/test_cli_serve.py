"""``mtm serve create-admin`` and ``mtm serve demo-lab`` (the server itself: tests/web)."""

from __future__ import annotations

import json

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.history import open_history
from mtmetrology.history.audit import AuditEntry, User
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.web.lab import Lab

runner = CliRunner()


def _mtm(*args, env=None):
    return runner.invoke(app, [str(a) for a in args], env=env)


def test_create_admin(tmp_path):
    db = tmp_path / "h.sqlite"
    made = _mtm(
        "serve", "create-admin", "boss", "--db", db, env={"MTM_ADMIN_PASSWORD": "a long password"}
    )
    assert made.exit_code == 0, made.output
    with Session(open_history(db)) as session:
        user = session.scalar(select(User).where(User.username == "boss"))
        assert user.role == "admin" and user.password_hash.startswith("$argon2id$")
        actions = list(session.scalars(select(AuditEntry.action)))
    assert actions == ["user-create"]
    short = _mtm("serve", "create-admin", "other", "--db", db, env={"MTM_ADMIN_PASSWORD": "short"})
    assert short.exit_code == 2
    taken = _mtm(
        "serve", "create-admin", "boss", "--db", db, env={"MTM_ADMIN_PASSWORD": "a long password"}
    )
    assert taken.exit_code == 2


def _pset(name: str, rng) -> dict:
    m = Machine.load(name)
    return ParameterSet(
        m.parameter_names,
        rng.normal(size=m.n_params) * m.parameter_scales,
        m.parameter_units,
        np.diag((0.5 * m.parameter_scales) ** 2),
        machine=m.name,
        model=m.model_name,
    ).to_document()


def test_demo_lab(tmp_path):
    demo = tmp_path / "demo"
    rng = np.random.default_rng(5)
    for folder, name, doc in (
        ("samba", "params.json", _pset("five-axis-wcbxfzyst", rng)),
        ("cmm", "calibration.json", _pset("cmm-moving-bridge", rng)),
        (
            "gauge",
            "length-check.json",
            # as samba.verify writes it: the document names its machine and category
            {
                "kind": "length-check",
                "version": 1,
                "machine": "five-axis-wcbxfzyst",
                "category": "verification",
            },
        ),
    ):
        (demo / folder).mkdir(parents=True)
        (demo / folder / name).write_text(json.dumps(doc))
    db = tmp_path / "lab.sqlite"
    assert _mtm("serve", "demo-lab", "--from", tmp_path, "--db", db).exit_code == 2  # not a demo
    made = _mtm("serve", "demo-lab", "--from", demo, "--db", db)
    assert made.exit_code == 0, made.output
    overview = Lab(open_history(db)).overview()
    assert [(m.name, m.runs) for m in overview] == [
        ("cmm-moving-bridge", 24),
        ("five-axis-wcbxfzyst", 24),
    ]
    assert overview[1].due_parameter == "E_X0C"  # its MPE is set
    with Session(open_history(db)) as session:
        added = list(session.scalars(select(AuditEntry).where(AuditEntry.action == "add")))
    # one audit row per recorded result (48 calibrations, the length check), by "demo"
    assert len(added) == 49 and {e.actor for e in added} == {"demo"}
    assert _mtm("serve", "demo-lab", "--from", demo, "--db", db).exit_code == 2  # not empty


def test_serve_refuses_no_workers(tmp_path):
    refused = _mtm("serve", "--db", tmp_path / "h.sqlite", "--workers", "0")
    assert refused.exit_code == 2
    assert not (tmp_path / "h.sqlite").exists()  # refused before the history is opened
