"""A virtual SAMBA test: the example artefact, ball layout, probing programme (4 balls +
scale bar, 111 indications) and true errors of Sepahi Boroujeni (2021) Table 5-2 size."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.samba import calibrate, load_artefact, load_balls, read_poses

from .samba_helpers import EXAMPLES, MACHINE, NOISE, simulate


@pytest.fixture(scope="session")
def machine13() -> Machine:
    return Machine.load(MACHINE, "13")


@pytest.fixture(scope="session")
def artefact():
    return load_artefact(EXAMPLES / "artefact.yaml")


@pytest.fixture(scope="session")
def balls():
    return load_balls(EXAMPLES / "balls.yaml").centres()


@pytest.fixture(scope="session")
def programme():
    return read_poses(EXAMPLES / "poses.csv")


@pytest.fixture(scope="session")
def truth13(machine13) -> np.ndarray:
    return ParameterSet.load(EXAMPLES / "truth.json", machine13).vector_for(machine13)


@pytest.fixture
def simulated(tmp_path, machine13, truth13, balls, programme, artefact):
    """``simulated(**options)``: records of the virtual 13-parameter test, written to a CSV
    and read back (options of :func:`mtmetrology.samba.simulate_records`, ``name``)."""
    return functools.partial(simulate, tmp_path, machine13, truth13, balls, programme, artefact)


@pytest.fixture(scope="session")
def noisy_calibration(tmp_path_factory, machine13, truth13, balls, programme, artefact):
    """One simulated test with 0.5 µm noise, calibrated with the tool estimated."""
    tmp = tmp_path_factory.mktemp("samba")
    rec = simulate(tmp, machine13, truth13, balls, programme, artefact, noise=NOISE, seed=11)
    return calibrate(machine13, rec, artefact, sigma=NOISE, estimate_tool=True)
