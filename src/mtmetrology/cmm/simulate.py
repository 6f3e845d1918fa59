"""Virtual CMM: ball-plate records from a machine with known errors (Salacheep 2016, §2.10).

The true plate is the calibrated plate plus a draw from its certificate covariance (so the
certificate uncertainty is real in the simulation); each position places it by
``c = R y + o`` (``R`` from ``rotation_deg``, fixed axes X, Y, Z; ``o`` = ``origin_mm``);
the readings that put each stylus at each true centre come from the inverse kinematics of
the engine (:meth:`Machine.inverse`) with the true errors, plus normal noise of standard
deviation σ on every reading.

References
----------
Salacheep, P. (2016). *Error Compensation and Uncertainty Evaluation of CMMs Based on
Kinematic Error Models and Gaussian Processes*. MPhil thesis, Brunel University London,
Appendix 2 (readings from true centres by inverting the model, then noise).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mtmetrology.cmm.files import (
    BallPlate,
    BallPlateRecords,
    PositionSet,
    ProbeSet,
    rotation_matrix,
)
from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.rng import as_generator
from mtmetrology.units import to_internal

__all__ = ["SimulatedCampaign", "simulate_ballplate"]

#: Fixed-point steps for a residual error: each shrinks the reading error by about
#: ‖∂e/∂q‖ (≈ 1e-5 for µm over 100 mm), so three reach the rounding of the inverse.
RESIDUAL_ITERATIONS = 3


@dataclass(frozen=True)
class SimulatedCampaign:
    """Records with the truth behind them.

    Attributes
    ----------
    records : BallPlateRecords
    true_plate : ndarray, shape (n_balls, 3)
        True ball centres in the plate frame, mm (plate order).
    true_points : ndarray, shape (n, 3)
        True machine-frame ball centre of every indication, mm.
    """

    records: BallPlateRecords
    true_plate: np.ndarray
    true_points: np.ndarray


def simulate_ballplate(
    machine: Machine,
    theta,
    plate: BallPlate,
    positions: PositionSet,
    probes: ProbeSet,
    *,
    sigma: float,
    seed=None,
    perturb_plate: bool = True,
    residual_error: Callable[[np.ndarray], np.ndarray] | None = None,
) -> SimulatedCampaign:
    """Simulate ball-plate records (``position,ball,probe,X,Y,Z``).

    Parameters
    ----------
    machine : Machine
        The CMM with the error parameters of ``theta`` active.
    theta : array_like, shape (n_params,), or None
        True errors, internal units (None: no errors).
    plate, positions, probes
        Plate (certificate), positions (pose and styli), probe set.
    sigma : float
        Standard deviation of the reading noise, mm (0 for exact readings).
    seed : int or Generator
    perturb_plate : bool
        Draw the true plate from the certificate covariance (else the true plate is the
        certificate).
    residual_error : callable, optional
        ``e(q)``: readings (n, 3) mm → error (n, 3) mm that the kinematic model cannot
        represent (a non-rigid deformation, a term in a product of two axis positions):
        the stylus centre is at ``p(q; θ, t) + e(q)``. A positive component moves the
        stylus along the positive machine axis. The readings solve
        ``p(q; θ, t) = c − e(q)`` by fixed-point iteration (e is µm-level and smooth).

    Returns
    -------
    SimulatedCampaign
    """
    rng = as_generator(seed)
    y = plate.coordinates
    if perturb_plate:
        chol = np.linalg.cholesky(plate.covariance)
        y = y + (chol @ rng.standard_normal(y.size)).reshape(y.shape)
    pos_ids, balls, probe_ids, targets, tools = [], [], [], [], []
    for pos in positions.positions:
        rot = rotation_matrix(to_internal(np.asarray(pos.rotation_deg), "deg"))
        centres = y @ rot.T + np.asarray(pos.origin_mm)
        for pid in pos.probes:
            t = probes.offsets([pid])[0]
            for b, c in zip(plate.ids, centres, strict=True):
                pos_ids.append(pos.id)
                balls.append(b)
                probe_ids.append(pid)
                targets.append(c)
                tools.append(t)
    targets, tools = np.array(targets), np.array(tools)
    if theta is None:
        theta = np.zeros(machine.n_params)
    start = targets - tools
    q = machine.inverse(targets, start, theta, tool=tools)
    if residual_error is not None:
        for _ in range(RESIDUAL_ITERATIONS):
            q = machine.inverse(targets - residual_error(q), q, theta, tool=tools)
    _check_travel(machine, q, pos_ids, balls, probe_ids)
    q = q + sigma * rng.standard_normal(q.shape)
    records = BallPlateRecords(
        tuple(pos_ids), tuple(balls), tuple(probe_ids), q, np.arange(2, len(q) + 2)
    )
    return SimulatedCampaign(records, y, targets)


def _check_travel(machine, q, positions, balls, probes) -> None:
    """Refuse a set-up the machine cannot measure: a reading outside an axis's travel."""
    for k, name in enumerate(machine.axis_names):
        travel = machine.axes[name].travel
        if travel is None:
            continue
        outside = (q[:, k] < travel[0]) | (q[:, k] > travel[1])
        if outside.any():
            i = int(np.argmax(outside))
            raise InputError(
                f"plate position {positions[i]!r}, ball {balls[i]!r}, probe {probes[i]!r}: "
                f"needs {name} = {q[i, k]:.3f} mm, outside the travel "
                f"[{travel[0]:g}, {travel[1]:g}] mm; move or turn the plate"
            )
