"""Shared set-ups of the tracker tests: the paper's mesh and pose on the XFYZ preset."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.kinematics import Machine
from mtmetrology.tracker import PAPER_POSE, parse_mesh

PAPER_MESH = "800:1200:100,100:500:100,200:400:100"
THREE_TOOLS = np.array([[0.0, 0.0, -100.0], [100.0, 0.0, -100.0], [0.0, 100.0, -100.0]])


@pytest.fixture(scope="module")
def machine():
    return Machine.load("three-axis-xfyz")


@pytest.fixture(scope="module")
def mesh(machine):
    return parse_mesh(PAPER_MESH, machine)


@pytest.fixture(scope="module")
def pose():
    return PAPER_POSE
