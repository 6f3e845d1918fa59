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

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mtmetrology.display import NotebookRepr
from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.units import from_internal

__all__ = [
    "CHUNK_ROWS",
    "Compensation",
    "compensate",
    "compensated_points",
    "compensation_covariance",
    "correction_statistics",
]

#: Rows evaluated at once: bounds the memory of the kinematic chain on large records.
CHUNK_ROWS = 1 << 16


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

    Parameters are those of :func:`compensation_covariance`.

    Returns
    -------
    points : (n, 3) ndarray, mm
    u : (n, 3) ndarray, mm
        √diag(G_s U_θ G_sᵀ) of each point s: only the diagonal is formed (a third of the
        products of the full 3 × 3 covariance; this runs on every row of ``mtm predict --u``).
    """
    ev = machine.evaluate(readings, parameters, senses=senses, tool=tool, d_params=True)
    g = np.asarray(ev.d_params).reshape(-1, 3, machine.n_params)
    variance = np.einsum("sip,sip->si", g @ np.asarray(covariance, float), g)
    return np.asarray(ev.position).reshape(-1, 3), np.sqrt(np.maximum(variance, 0.0))


@dataclass(frozen=True)
class Compensation(NotebookRepr):
    """Compensated stylus-centre coordinates of a record (:func:`compensate`).

    Attributes
    ----------
    points : (n, 3) ndarray, mm
        f(φ, δ̂) in the workpiece frame.
    u : (n, 3) ndarray or None, mm
        Standard uncertainty of each coordinate (None when not asked for).
    """

    points: np.ndarray
    u: np.ndarray | None = None

    def to_dict(self) -> dict:
        """``compensated-points`` document (mm)."""
        return {
            "kind": "compensated-points",
            "version": 1,
            "unit": "mm",
            "points": self.points.tolist(),
            "u": None if self.u is None else self.u.tolist(),
        }

    @classmethod
    def from_dict(cls, document: dict) -> Compensation:
        """Inverse of :meth:`to_dict`."""
        u = document.get("u")
        return cls(
            np.asarray(document["points"], dtype=float).reshape(-1, 3),
            None if u is None else np.asarray(u, dtype=float).reshape(-1, 3),
        )


def compensate(
    machine: Machine,
    readings: np.ndarray,
    parameters: np.ndarray | None = None,
    covariance: np.ndarray | None = None,
    *,
    senses: np.ndarray | None = None,
    tool: np.ndarray | None = None,
    error_model=None,
    with_u: bool = False,
    source: str = "readings",
    lines: Sequence[int] | None = None,
    chunk_rows: int = CHUNK_ROWS,
) -> Compensation:
    """Compensated coordinates q = f(φ, δ̂) of a record, evaluated in chunks of rows.

    With ``with_u``, u(q_i) = √[G U_θ Gᵀ]_ii, G = ∂f/∂δ (:func:`compensated_points`), or
    the posterior standard deviation of ``error_model``.

    Parameters
    ----------
    machine : Machine
    readings : (n, n_axes) array
        Internal readings (mm, rad).
    parameters : (P,) array, optional
        δ̂, internal units (zero when omitted).
    covariance : (P, P) array, optional
        U_θ of δ̂; required by ``with_u`` without an ``error_model``.
    senses : (n, n_axes) array, optional
        +1/−1 traverse senses; required when the machine has reversal terms.
    tool : (3,) or (n, 3) array, optional
        Tool vector, mm (the machine's when omitted).
    error_model : object with ``predict(readings, tools) -> (points, u)``, optional
        A non-parametric error model (e.g. :class:`mtmetrology.cmm.gp.GPErrorModel`) used
        instead of ``parameters``.
    with_u : bool
        Also return the standard uncertainty of each coordinate.
    source, lines
        The file and line of each row, named by the errors.
    chunk_rows : int
        Rows evaluated at once (bounds the memory of the kinematic chain).

    Returns
    -------
    Compensation

    Raises
    ------
    InputError
        ``with_u`` without a covariance, reversal terms without senses, or a row whose
        compensated position is not finite.

    References
    ----------
    JCGM 100:2008, 5.1.2.
    """
    if with_u and covariance is None and error_model is None:
        raise InputError("the uncertainty of compensated points needs a parameter covariance")
    reversal = [p for p in machine.parameters if p.kind == "reversal"]
    if reversal and senses is None:
        columns = ", ".join(sorted({f"sense_{p.axis}" for p in reversal}))
        raise InputError(
            f"{source}: the parameter set has reversal terms "
            f"({', '.join(p.name for p in reversal)}); add the sense-of-motion column(s) "
            f"{columns} (+1 or -1)"
        )
    n = len(readings)
    points = np.empty((n, 3))
    u = np.empty((n, 3)) if with_u else None
    for start in range(0, n, chunk_rows):
        rows = slice(start, start + chunk_rows)
        t = tool if tool is None or np.ndim(tool) == 1 else tool[rows]
        t = machine.tool if t is None else t
        s_rows = None if senses is None else senses[rows]
        if error_model is not None:
            points[rows], u_model = error_model.predict(readings[rows], t)
            if u is not None:
                u[rows] = u_model
        elif u is not None:
            points[rows], u[rows] = compensated_points(
                machine, readings[rows], parameters, covariance, senses=s_rows, tool=t
            )
        else:
            points[rows] = machine.forward(readings[rows], parameters, senses=s_rows, tool=t)
    bad = ~np.isfinite(points).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise InputError(
            f"{source}, line {i + 1 if lines is None else lines[i]}: the compensated position "
            "is not finite; check the readings and the parameter set"
        )
    return Compensation(points, u)


def correction_statistics(
    points: np.ndarray, nominal: np.ndarray
) -> tuple[np.ndarray, float, float]:
    """The correction each point receives from the error model, and its size.

    Parameters
    ----------
    points, nominal : (n, 3) array, mm
        Compensated and nominal (error-free) positions.

    Returns
    -------
    correction : (n, 3) ndarray, µm
        ``points - nominal``.
    largest, rms : float, µm
        max_i ‖c_i‖ and √(mean_i ‖c_i‖²).
    """
    correction = from_internal(np.asarray(points) - np.atleast_2d(nominal), "µm")
    size = np.linalg.norm(correction, axis=1)
    return correction, float(size.max()), float(np.sqrt(np.mean(size**2)))
