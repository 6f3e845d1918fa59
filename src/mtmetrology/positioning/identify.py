"""The ISO 230-1 positioning error function of the tested axis, identified from the run.

The readings of an ISO 230-2 test are observations of the axis's positioning error motion
``E_XX(x)`` (error direction = moving axis) and its reversal term ``E_XXb`` in the project's
basis (:mod:`mtmetrology.kinematics.basis`), through the one kinematic chain: at target
``P_i`` with sense ``s = ±1``,

    x_ij = [p(q_i, s; θ) − p(q_i, s; 0)]_a + c + ε_ij,

``p`` the tool point in the workpiece frame (:meth:`Machine.forward`), ``a`` the axis's
component, ``c`` the laser datum (a nuisance unknown: the laser is zeroed at a target whose
own error is unknown; the models hold no constant term) and ``ε_ij`` the scatter of one
reading, of standard uncertainty the pooled ``s`` of the test.  The identification engine
(:func:`~mtmetrology.identification.solver.levenberg_marquardt`) solves it with the
project's rank diagnostics; the covariance is scaled by the model-adequacy rule
(``with_adequacy``), so what the polynomial cannot follow widens it.  The resulting
:class:`~mtmetrology.kinematics.parameter_set.ParameterSet` combines with SAMBA, tracker
and multilateration sets of the same machine and model basis, and ``mtm export`` reads it
from the result document.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.identification.solver import levenberg_marquardt
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.units import from_internal

__all__ = ["axis_machine", "identify_axis", "readings_along"]

_COMPONENT = {"X": 0, "Y": 1, "Z": 2}


def axis_machine(machine: Machine, axis: str, degrees: Sequence[int] | None = None) -> Machine:
    """``machine`` with only ``E_<axis><axis>`` (its model's degrees, or ``degrees``) and
    the reversal term ``E_<axis><axis>b`` active.

    Raises
    ------
    InputError
        Not a linear axis of the machine, or no degree to identify.
    """
    if axis not in machine.axis_names or axis not in _COMPONENT:
        raise InputError(f"axis: {axis!r} is not a linear axis of {machine.name}")
    stem = f"E_{axis}{axis}"
    if degrees is None:
        degrees = [
            p.degree
            for p in machine.parameters
            if p.kind == "motion" and p.axis == axis and p.name.startswith(stem)
        ]
    if not degrees:
        raise InputError(f"{machine.name}: the model has no {stem} terms; give the degrees")
    names = [f"{stem}{d}" for d in sorted(set(degrees))] + [f"{stem}b"]
    return machine.with_parameters(names)


def readings_along(machine: Machine, axis: str, positions: np.ndarray) -> np.ndarray:
    """Machine readings with ``axis`` at ``positions`` (mm) and every other axis at the
    middle of its travel (0 without one), shape (n, n_axes)."""
    q = np.zeros((positions.size, machine.n_axes))
    for k, name in enumerate(machine.axis_names):
        travel = machine.axes[name].travel
        q[:, k] = 0.0 if travel is None else 0.5 * (travel[0] + travel[1])
    q[:, machine.axis_names.index(axis)] = positions
    return q


class _AxisProblem:
    """Weighted linear least squares ``(A θ + c − x)/σ`` in the solver's protocol."""

    def __init__(self, design: np.ndarray, x: np.ndarray, sigma: float, names: tuple):
        self.names = (*names, "laser_datum")
        self._a = np.column_stack([design, np.ones(x.size)]) / sigma
        self._b = x / sigma

    def initial(self) -> np.ndarray:
        return np.zeros(self._a.shape[1])

    def evaluate(self, theta: np.ndarray, jacobian: bool = True):
        return self._a @ theta - self._b, self._a


def identify_axis(
    machine: Machine,
    axis: str,
    targets: np.ndarray,
    deviations: np.ndarray,
    *,
    degrees: Sequence[int] | None = None,
    provenance: dict | None = None,
) -> tuple[ParameterSet, dict]:
    """Identify ``E_XX`` and ``E_XXb`` of one axis from its ISO 230-2 deviations.

    Parameters
    ----------
    machine : Machine
        The machine the axis belongs to (its model's basis and travel).
    axis : str
    targets : ndarray, shape (m,)
        Target positions, mm.
    deviations : ndarray, shape (m, n, 2)
        ``x_ij`` in mm, approach ↑ then ↓ (after any environmental correction).
    degrees : sequence of int, optional
        Degrees of ``E_XX`` (the model's when omitted).
    provenance : dict, optional

    Returns
    -------
    parameters : ParameterSet
        ``E_XX<d>`` and ``E_XXb`` with covariance (the datum dropped).
    summary : dict
        ``max_mean_misfit_um`` (largest |x̄_i − fit| over the targets), ``sigma_um`` (the
        pooled s used as the reading's u), ``rms_residual_um``, ``dof``,
        ``variance_factor``, ``message``.

    Raises
    ------
    InputError
        A bad axis, a target outside the travel.
    RankDeficientError
        More degrees than the targets can separate.
    """
    sub = axis_machine(machine, axis, degrees)
    travel = sub.axes[axis].travel
    if travel is not None and (
        targets.min() < travel[0] - 1e-9 or targets.max() > travel[1] + 1e-9
    ):
        raise InputError(
            f"targets: {targets.min():g} to {targets.max():g} mm outside the travel of {axis} "
            f"({travel[0]:g} to {travel[1]:g} mm)"
        )
    m, n, _ = deviations.shape
    q = readings_along(sub, axis, targets)
    q = np.repeat(q[:, None, None, :], n, axis=1).repeat(2, axis=2).reshape(-1, sub.n_axes)
    senses = np.zeros_like(q)
    senses[:, sub.axis_names.index(axis)] = np.tile([1.0, -1.0], m * n)
    design = sub.jacobian(q, senses=senses)[:, _COMPONENT[axis], :]
    x = deviations.reshape(-1)
    sigma = float(np.sqrt(np.mean(deviations.var(axis=1, ddof=1))))
    sigma = max(sigma, 1e-9)  # a noise-free (simulated) run: weights stay finite
    result = levenberg_marquardt(_AxisProblem(design, x, sigma, sub.parameter_names))
    result = result.with_adequacy("scale")
    pset = result.parameter_set(sub, {"source": "ISO 230-2 laser run", **(provenance or {})})
    res = result.residuals * sigma
    # how far the fitted function is from the pitch table (x̄_i of both directions): what
    # the polynomial cannot follow (a periodic error, say) shows here, not in u
    misfit = np.abs(res.reshape(m, n, 2).mean(axis=(1, 2))).max()
    return pset, {
        "max_mean_misfit_um": from_internal(float(misfit), "µm"),
        "sigma_um": from_internal(sigma, "µm"),
        "rms_residual_um": from_internal(float(np.sqrt(np.mean(res**2))), "µm"),
        "dof": int(result.dof),
        "variance_factor": result.variance_factor,
        "message": result.message,
    }
