"""A demonstration laboratory built from the output of ``mtm demo`` (``make serve``).

The demo calibrates two machines once each (the five-axis machine with SAMBA, the bridge
CMM with a ball plate). A laboratory has years of calibrations, so each is repeated
monthly over two years up to today: the same document with its values moved by a drift
(a constant slope per parameter plus a random walk) and by noise of the run's own standard
uncertainty, all from a fixed seed (:mod:`mtmetrology.rng`). The five-axis machine's E_X0C
drifts towards its MPE (due soon), the CMM is stable (ok); the demo's length check and
task results are recorded with the five-axis machine. Users ``admin``, ``engineer`` and
``viewer`` get the password ``demo-password`` (a demonstration only).
"""

from __future__ import annotations

import copy
import json
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.history.records import add_result
from mtmetrology.history.series import machine_names
from mtmetrology.history.settings import set_lab_settings, set_machine_limit
from mtmetrology.rng import as_generator

__all__ = ["DEMO_PASSWORD", "build_demo_lab"]

DEMO_PASSWORD = "demo-password"
MONTHS = 24
SEED = 2034


def _series(document: dict, rng, months: int, drift: dict[str, float]) -> list[dict]:
    """``months`` copies of ``document``: value_k = value + slope·k + walk_k + noise_k."""
    out = []
    parameters = document["parameters"]
    u = np.array([p.get("u", 0.0) or 0.0 for p in parameters])
    walk = np.zeros(len(parameters))
    for k in range(months):
        walk = walk + rng.normal(0.0, 0.3, len(parameters)) * u
        doc = copy.deepcopy(document)
        for j, p in enumerate(doc["parameters"]):
            slope = drift.get(p["name"], 0.0)
            p["value"] = float(p["value"] + slope * k + walk[j] + rng.normal(0.0, u[j] or 0.1))
        doc["provenance"] = {**doc.get("provenance", {}), "demo_month": k}
        out.append(doc)
    return out


def build_demo_lab(engine, demo: str | Path, now: datetime | None = None) -> str:
    """Fill an empty history with the demonstration laboratory; returns a summary line.

    Raises
    ------
    InputError
        ``demo`` is not a folder written by ``mtm demo``, or the history is not empty.
    """
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.web.security import create_user

    demo = Path(demo)
    needed = {
        "five": demo / "samba" / "params.json",
        "cmm": demo / "cmm" / "calibration.json",
        "length": demo / "gauge" / "length-check.json",
    }
    missing = [str(p) for p in needed.values() if not p.is_file()]
    if missing:
        raise InputError(f"{demo}: not the output of mtm demo ({missing[0]} missing)")
    if machine_names(engine):
        raise InputError("the demonstration laboratory needs an empty history")
    now = now or datetime.now(UTC).replace(microsecond=0)
    rng = as_generator(SEED)
    start = now - timedelta(days=30 * MONTHS)
    count = 0
    by = "demo"
    for key, drift in (("five", {"E_X0C": 0.9}), ("cmm", {})):
        document = json.loads(needed[key].read_text())
        machine = Machine.load(document["machine"])
        for k, doc in enumerate(_series(document, rng, MONTHS, drift)):
            add_result(
                engine,
                doc,
                machine,
                source=str(needed[key]),
                performed_at=start + timedelta(days=30 * k),
                note=f"monthly calibration {k + 1}",
                temperature_c=float(20 + rng.normal(0, 0.3)),
                by=by,
            )
            count += 1
    five = Machine.load("five-axis-wcbxfzyst")
    add_result(
        engine,
        json.loads(needed["length"].read_text()),
        five,
        source=str(needed["length"]),
        performed_at=now - timedelta(days=3),
        note="length check after the last calibration",
        by=by,
    )
    for task in sorted((demo / "task").glob("sphere-*.json"))[:3]:
        add_result(
            engine,
            json.loads(task.read_text()),
            five,
            source=str(task),
            performed_at=now - timedelta(days=2),
            note=task.stem,
            by=by,
        )
    set_machine_limit(engine, five.name, "E_X0C", 40.0, 0.95, by=by)
    set_machine_limit(engine, "cmm-moving-bridge", "E_XX1", 25.0, 0.95, by=by)
    set_lab_settings(
        engine,
        {
            "laboratory": "Demonstration laboratory",
            "email": "lab@example.org",
            "country": "DE",
            "responsible_person": "A. Metrologist",
            "manufacturer": "Virtual machine tools",
        },
        by=by,
    )
    for role in ("admin", "engineer", "viewer"):
        create_user(engine, role, DEMO_PASSWORD, role, by=by)
    return (
        f"demonstration laboratory: {count} calibrations of 2 machines; users admin, engineer, "
        f"viewer with password {DEMO_PASSWORD!r}"
    )
