"""Parameter sets of the presets with chosen errors, for the export tests."""

import numpy as np
import pytest

from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet


def _parameter_set(machine: Machine, values: dict, u: dict | None = None) -> ParameterSet:
    """A set of ``machine``'s active model with ``values`` (customary units), others zero.

    ``u`` gives standard uncertainties (customary units); a diagonal covariance is formed.
    """
    theta = np.zeros(machine.n_params)
    for name, value in values.items():
        theta[machine.parameter_names.index(name)] = value
    theta = theta * machine.parameter_scales
    cov = None
    if u is not None:
        sd = np.zeros(machine.n_params)
        for name, value in u.items():
            sd[machine.parameter_names.index(name)] = value
        cov = np.diag((sd * machine.parameter_scales) ** 2)
    return ParameterSet(
        machine.parameter_names,
        theta,
        machine.parameter_units,
        cov,
        machine=machine.name,
        model=machine.model_name,
    )


@pytest.fixture
def make_set():
    """``make_set(machine, values, u=None)``: see :func:`_parameter_set`."""
    return _parameter_set


REVERSAL_MACHINE = """kind: machine
version: 1
name: reversal-test
topology: WXFYZT
axes:
  X: {travel_mm: [0, 400]}
  Y: {travel_mm: [0, 300]}
  Z: {travel_mm: [0, 200]}
error_models:
  m:
    basis: monomial
    motions:
      E_XX: [1]
    parameters: [E_XXb]
"""


@pytest.fixture
def reversal_machine(tmp_path):
    """A three-axis machine whose X has a positioning slope E_XX1 (µm/m) and a reversal
    term E_XXb (µm): the error is E_XX1 · x + E_XXb · sense."""
    path = tmp_path / "reversal.yaml"
    path.write_text(REVERSAL_MACHINE)
    return Machine.load(path)


#: Positioning errors of the three-axis preset, large against their u (0.3), so that most
#: check points of the verification tell a correct table from a flipped one (|r − e| > 2 U_c).
VERIFICATION_ERRORS = {"E_XX1": 30.0, "E_XX2": -6.0, "E_YY1": -25.0, "E_ZZ1": 20.0, "E_YX2": 4.0}


@pytest.fixture(scope="module")
def exported():
    """(parameter set, result, verification files) of a LinuxCNC export at a 20 mm pitch
    with the check programme at 5 positions per axis."""
    from mtmetrology.export.verification import export_with_verification

    machine = Machine.load("three-axis-xfyz")
    u = dict.fromkeys(VERIFICATION_ERRORS, 0.3)
    pset = _parameter_set(machine, VERIFICATION_ERRORS, u)
    result, files = export_with_verification(
        machine, pset, "linuxcnc", verify_positions=5, pitch=20, when="T"
    )
    return pset, result, files
