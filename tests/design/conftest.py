"""Machines and ball layouts shared by the design tests."""

import pytest

from mtmetrology.kinematics import Machine


@pytest.fixture(scope="session")
def m13():
    return Machine.load("five-axis-wcbxfzyst", "13")


@pytest.fixture(scope="session")
def m84():
    return Machine.load("five-axis-wcbxfzyst", "84")
