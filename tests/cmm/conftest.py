"""Fixtures: a virtual bridge CMM with known errors, a ball plate and styli."""

from __future__ import annotations

import numpy as np
import pytest
from cmm_virtual import make_plate

from mtmetrology.cmm.calibrate import model_machine
from mtmetrology.cmm.files import BallPlate, ProbeSet
from mtmetrology.kinematics import Machine


@pytest.fixture(scope="session")
def base() -> Machine:
    return Machine.load("cmm-moving-bridge")


@pytest.fixture(scope="session")
def probes() -> ProbeSet:
    offsets = {
        "P0": [0, 0, -150],
        "PX1": [50, 0, -150],
        "PX2": [-50, 0, -150],
        "PY1": [0, 50, -150],
        "PY2": [0, -50, -150],
    }
    return ProbeSet(
        kind="probe-set", probes=[{"id": k, "offset_mm": v} for k, v in offsets.items()]
    )


@pytest.fixture(scope="session")
def plate3() -> BallPlate:
    return make_plate(3, 266.0)


@pytest.fixture(scope="session")
def truth(base):
    """Full degree-3 model (straightness of degree 3 included) with errors of a few µm."""
    machine, _ = model_machine(base, "full-3")
    rng = np.random.default_rng(1)
    theta = np.array(
        [
            rng.normal(0.0, 10e-6 if p.is_rotation else 0.004)
            if p.kind == "motion"
            else rng.normal(0.0, 10e-6)
            for p in machine.parameters
        ]
    )
    return machine, theta
