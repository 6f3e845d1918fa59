"""Uncertainty of compensated coordinates from the calibration's parameter covariance.

A point probed with readings φ is compensated with the calibration's estimate δ̂ of the
machine parameters: q = f(φ, δ̂).  The estimate is δ̂ = Δ + ε with ε ~ (0, U_θ) (the
identification's covariance), independent of the readings, so to first order

    U_q = G U_θ Gᵀ,    G = ∂f/∂δ at (φ, δ̂),

for each point, and the standard uncertainty of each coordinate is √[G U_θ Gᵀ]_ii.  The
readings are taken as exact here (their repeatability and the machine's drift since the
calibration are task terms: :mod:`mtmetrology.omm.task`).

References
----------
JCGM 100:2008. *Evaluation of measurement data — Guide to the expression of uncertainty in
measurement*, 5.1.2 (law of propagation of uncertainty).
"""

from __future__ import annotations

import numpy as np

from mtmetrology.kinematics.machine import Machine

__all__ = ["compensated_points", "compensation_covariance"]


def compensation_covariance(
    machine: Machine,
    readings: np.ndarray,
    parameters: np.ndarray,
    covariance: np.ndarray,
    *,
    senses: np.ndarray | None = None,
    tool: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Compensated points f(φ, δ̂) and the covariance G U_θ Gᵀ of each.

    Parameters
    ----------
    machine : Machine
    readings : (n, n_axes) array
        Internal readings (mm, rad).
    parameters : (P,) array
        δ̂ (internal units, ``machine.parameter_names`` order).
    covariance : (P, P) array
        U_θ of δ̂, internal units.
    senses : (n, n_axes) array, optional
    tool : (3,) or (n, 3) array, optional
        Tool vector, mm (the machine's when omitted).

    Returns
    -------
    points : (n, 3) ndarray, mm
    covariance : (n, 3, 3) ndarray, mm²
        G_s U_θ G_sᵀ of each point s (G_s = ∂f/∂δ, analytic).
    """
    ev = machine.evaluate(readings, parameters, senses=senses, tool=tool, d_params=True)
    g = np.asarray(ev.d_params).reshape(-1, 3, machine.n_params)
    cov = np.einsum("sip,pq,sjq->sij", g, np.asarray(covariance, float), g)
    return np.asarray(ev.position).reshape(-1, 3), cov


def compensated_points(
    machine: Machine,
    readings: np.ndarray,
    parameters: np.ndarray,
    covariance: np.ndarray,
    *,
    senses: np.ndarray | None = None,
    tool: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Compensated points f(φ, δ̂) and the standard uncertainty of each coordinate.

    Parameters
    ----------
    machine : Machine
    readings : (n, n_axes) array
        Internal readings (mm, rad).
    parameters : (P,) array
        δ̂ (internal units, ``machine.parameter_names`` order).
    covariance : (P, P) array
        U_θ of δ̂, internal units.
    senses : (n, n_axes) array, optional
    tool : (3,) or (n, 3) array, optional
        Tool vector, mm (the machine's when omitted).

    Returns
    -------
    points : (n, 3) ndarray, mm
    u : (n, 3) ndarray, mm
        √diag(G_s U_θ G_sᵀ) of each point s.
    """
    points, cov = compensation_covariance(
        machine, readings, parameters, covariance, senses=senses, tool=tool
    )
    return points, np.sqrt(np.maximum(np.diagonal(cov, axis1=1, axis2=2), 0.0))
