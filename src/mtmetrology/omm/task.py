"""Task uncertainty of an on-machine measurement by the full-covariance method (GUF).

The inputs of the on-machine measurement function are the long-term axis positions Γ
of every probed point and the machine parameters Δ (Sepahi Boroujeni (2021), §6.2), plus
the unexplained volumetric errors E added to the compensated points (eq. 6-14). Their
covariance U_x is that of the covariance simulator (Populations I–IV, §6.2.2), here
in its first-order (linearised) form, so no sampling noise enters the GUF:

    Ψ_s − ψ_s = A_s (Φ_s − φ_s)                       Population II, A_s = ∂f/∂q
    Γ_s − φ_s = L F_s⁻¹ [(Ψ_s − ψ_s) − G_s (Δ − δ)]   Population IV, F_s = A_s L (X, Y, Z)

with Φ_s ~ N(φ_s, v_s) (the repeatability model's 5×5 v_i) and Δ ~ N(δ, Σ) (the
long-term parameter covariance). The compensated points q_s = f(Γ_s, Δ) + e_s and the
feature g(q) are propagated by the library's GUF engine with the analytic sensitivities
[G A_s, G G_s, G] (G = the feature's Jacobian).

To first order the machine-parameter uncertainty cancels: A_s (Γ_s − φ_s) + G_s (Δ − δ)
= Ψ_s − ψ_s, so U_q = blockdiag(A_s v_s A_sᵀ) + I ⊗ cov(e) whatever Σ is, and the
budget's machine-parameter share is zero up to rounding. The parameters enter the
*value* (the compensation), not its first-order uncertainty.

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, ch. 6 and 7.

JCGM 102:2011. *Evaluation of measurement data — Supplement 2 to the GUM — Extension to
any number of output quantities*, 6.2.1.3.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology.budgets.conformity import ConformityDecision
from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.omm.repeatability import RepeatabilityModel
from mtmetrology.uncertainty.guf import GUFResult, guf

__all__ = ["TaskResult", "pose_factors", "reading_covariance", "task_uncertainty"]

GROUPS = ("repeatability", "machine_parameters", "unexplained_volumetric_error")


def pose_factors(machine: Machine, readings: np.ndarray, approach: np.ndarray) -> np.ndarray:
    """Repeatability-model factors (φ, θ, B, C, X_T, Y_T, Z_T) of probed points.

    Parameters
    ----------
    machine : Machine
        Must have axes X, Y, Z, B and C.
    readings : (n, n_axes) array
        Internal readings (mm, rad).
    approach : (n, 3) array
        Approach directions (the probe moves along them), any length.

    Returns
    -------
    (n, 7) ndarray
        φ = arccos n_z, θ = atan2(n_x, n_y) in [0, 2π) of n̂ = −approach/‖approach‖
        (the inverse of Sepahi Boroujeni (2021), eq. A.4-2), B, C (rad), X, Y, Z (mm).

    Raises
    ------
    InputError
        A machine without X, Y, Z, B, C axes, or a zero approach vector.
    """
    names = machine.axis_names
    missing = [a for a in "XYZBC" if a not in names]
    if missing:
        raise InputError(
            f"machine {machine.name}: the repeatability model needs axes X, Y, Z, B, C "
            f"(missing {', '.join(missing)})"
        )
    a = np.asarray(approach, float)
    norm = np.linalg.norm(a, axis=-1)
    if np.any(norm == 0):
        raise InputError(
            f"approach (i, j, k) of point {int(np.flatnonzero(norm == 0)[0]) + 1} is zero"
        )
    n = -a / norm[:, None]
    phi = np.arccos(np.clip(n[:, 2], -1.0, 1.0))
    theta = np.mod(np.arctan2(n[:, 0], n[:, 1]), 2 * np.pi)
    cols = [readings[:, names.index(c)] for c in "BCXYZ"]
    return np.column_stack([phi, theta, *cols])


def reading_covariance(
    machine: Machine,
    model: RepeatabilityModel,
    readings: np.ndarray,
    approach: np.ndarray,
    *,
    strict: bool = True,
) -> np.ndarray:
    """Covariance v_s of each probed reading from a repeatability model.

    Parameters
    ----------
    machine : Machine
    model : RepeatabilityModel
    readings : (n, n_axes) array, mm and rad
    approach : (n, 3) array
        Approach directions of the touches.
    strict : bool
        Refuse (True) or warn about (False) poses outside the model's range.

    Returns
    -------
    (n, n_axes, n_axes) ndarray, mm²
        The model's PSD 3×3 block on the X, Y, Z readings, zero rows for every other
        axis (Sepahi Boroujeni (2021), §6.2: v_i with zero rotary rows).
    """
    c3 = model.covariance(pose_factors(machine, readings, approach), strict=strict)
    idx = [machine.axis_names.index(a) for a in "XYZ"]
    v = np.zeros((len(readings), machine.n_axes, machine.n_axes))
    v[:, np.array(idx)[:, None], np.array(idx)[None, :]] = c3
    return v


@dataclass(frozen=True)
class TaskResult:
    """Feature value and uncertainty of one on-machine measurement task.

    Attributes
    ----------
    guf : GUFResult
        The propagation (outputs, per-input budget) over Γ, Δ and E.
    points : (n, 3) ndarray, mm
        Compensated points f(φ_s, δ).
    points_covariance : (3n, 3n) ndarray, mm²
        U_q of the compensated points.
    shares : dict of str to (m,) ndarray
        Variance share of each output from the repeatability, the machine parameters
        (zero to first order, see the module notes) and E.
    decision : ConformityDecision or None
        ISO 14253-1:2017 decision when a tolerance was given (first output).
    """

    guf: GUFResult
    points: np.ndarray
    points_covariance: np.ndarray
    shares: dict
    decision: ConformityDecision | None = None

    def to_dict(self) -> dict:
        """``uncertainty-result`` document with the group budget and the decision."""
        doc = {"kind": "uncertainty-result", "version": 1, **self.guf.to_dict()}
        doc["budget_groups"] = {
            name: {g: float(self.shares[g][j]) for g in GROUPS}
            for j, name in enumerate(self.guf.names)
        }
        doc["points"] = {"unit": "mm", "compensated": self.points.tolist()}
        if self.decision is not None:
            doc["decision"] = self.decision.to_dict()
        return doc


class _Inputs:
    """The input set the GUF engine reads: names, units, estimate, covariance, dof."""

    def __init__(self, names, units, estimate, covariance):
        self.names, self.units = tuple(names), tuple(units)
        self.estimate, self.covariance = estimate, covariance
        self.dof = np.full(len(names), np.inf)
        u = np.sqrt(np.diag(covariance))
        live = u > 0
        self.correlation = np.eye(len(names))
        self.correlation[np.ix_(live, live)] = covariance[np.ix_(live, live)] / np.outer(
            u[live], u[live]
        )


def task_uncertainty(
    machine: Machine,
    readings: np.ndarray,
    parameters: np.ndarray,
    parameter_covariance: np.ndarray,
    feature,
    *,
    reading_covariance: np.ndarray | None = None,
    unexplained_covariance: np.ndarray | None = None,
    senses: np.ndarray | None = None,
    p: float = 0.95,
) -> TaskResult:
    """GUF of a feature measured on the machine, by the full-covariance method.

    Parameters
    ----------
    machine : Machine
        With exactly three linear axes (the inverse model solves for them).
    readings : (n, n_axes) array
        Probed readings φ_s (mm, rad).
    parameters : (P,) array
        Machine parameters δ (internal units, ``machine.parameter_names`` order).
    parameter_covariance : (P, P) array
        Long-term covariance Σ of the parameters.
    feature : mtmetrology.fitting.features.Feature
        ``value(points (n, 3))`` and ``jacobian(points) -> (m, 3n)``.
    reading_covariance : (n, n_axes, n_axes) array, optional
        v_s of each reading (e.g. :meth:`RepeatabilityModel.covariance5` embedded); none
        means perfect repeatability.
    unexplained_covariance : (3, 3) array, optional
        cov(e) of the unexplained volumetric errors, mm² (PSD).
    senses : (n, n_axes) array, optional
        Sense of motion per axis.
    p : float
        Coverage probability.

    Returns
    -------
    TaskResult

    Raises
    ------
    InputError
        Shapes that do not match the machine, a singular linear-axis Jacobian, or a
        covariance that is not positive semidefinite.
    """
    q = np.asarray(readings, float)
    n, n_axes = q.shape
    n_par = machine.n_params
    delta = np.asarray(parameters, float)
    sigma = _psd(parameter_covariance, (n_par, n_par), "parameter covariance")
    v = (
        np.zeros((n, n_axes, n_axes))
        if reading_covariance is None
        else _psd(reading_covariance, (n, n_axes, n_axes), "reading covariance")
    )
    cov_e = (
        np.zeros((3, 3))
        if unexplained_covariance is None
        else _psd(unexplained_covariance, (3, 3), "unexplained volumetric error covariance")
    )
    ev = machine.evaluate(q, delta, senses=senses, d_params=True, d_axes=True)
    points, a, g = ev.position, ev.d_axes, ev.d_params  # (n,3), (n,3,n_axes), (n,3,P)
    linear = [machine.axis_names.index(x) for x in machine.linear_axes]
    if len(linear) != 3:
        raise InputError(f"machine {machine.name}: the task model needs three linear axes")
    f_lin = a[:, :, linear]  # (n, 3, 3)
    if np.any(np.abs(np.linalg.det(f_lin)) < 1e-12):
        raise InputError("the linear axes do not span space at a probed pose (singular ∂f/∂q)")
    f_inv = np.linalg.inv(f_lin)
    # Population IV, linearised: Γ_s − φ_s = L F⁻¹ (A v-noise − G (Δ − δ)).
    w = a @ v @ np.swapaxes(a, 1, 2)  # (n, 3, 3) cov of Ψ_s
    m_par = -f_inv @ g  # (n, 3, P): ∂Γ_lin/∂Δ
    size = n * n_axes + n_par + 3 * n
    ux = np.zeros((size, size))
    lin = (np.arange(n)[:, None] * n_axes + np.array(linear)[None, :]).ravel()  # (3n,)
    par = slice(n * n_axes, n * n_axes + n_par)
    m_stack = m_par.reshape(3 * n, n_par)  # ∂Γ_lin/∂Δ of every point, stacked
    gamma_cov = m_stack @ sigma @ m_stack.T  # parameter-driven part, all point pairs
    own = f_inv @ w @ np.swapaxes(f_inv, 1, 2)  # (n, 3, 3): repeatability, per point
    for s in range(n):
        gamma_cov[3 * s : 3 * s + 3, 3 * s : 3 * s + 3] += own[s]
    ux[np.ix_(lin, lin)] = gamma_cov
    cross = m_stack @ sigma  # (3n, P)
    ux[lin, par] = cross
    ux[par, lin] = cross.T
    ux[par, par] = sigma
    e0 = n * n_axes + n_par
    ux[e0:, e0:] = np.kron(np.eye(n), cov_e)
    x = np.concatenate([q.ravel(), delta, np.zeros(3 * n)])
    feature_jac = np.atleast_2d(feature.jacobian(points))  # (m, 3n)

    def model(xx):
        gam = xx[..., : n * n_axes].reshape(*xx.shape[:-1], n, n_axes)
        dd = xx[..., par]
        pts = machine.forward(gam, dd[..., None, :], senses=senses)
        pts = pts + xx[..., e0:].reshape(*xx.shape[:-1], n, 3)
        return feature.value(pts)

    # ∂q/∂x = [blockdiag(A_s), G stacked, I]: (3n, N)
    c_axes = np.zeros((3 * n, n * n_axes))
    for s in range(n):
        c_axes[3 * s : 3 * s + 3, s * n_axes : (s + 1) * n_axes] = a[s]
    c_points = np.hstack([c_axes, g.reshape(3 * n, n_par), np.eye(3 * n)])

    def jacobian(_x):
        return feature_jac @ c_points

    axis_names, linear_names = machine.axis_names, machine.linear_axes
    names = [f"{ax}_{s + 1}" for s in range(n) for ax in axis_names]
    names += list(machine.parameter_names) + [f"e{c}_{s + 1}" for s in range(n) for c in "xyz"]
    units = [("mm" if ax in linear_names else "rad") for ax in axis_names] * n
    units += ["1"] * n_par + ["mm"] * (3 * n)
    result = guf(
        model,
        _Inputs(names, units, x, ux),
        jacobian=jacobian,
        p=p,
        output_names=list(feature.output_names),
        output_units=[feature.unit] * len(feature.output_names),
    )
    full = result.sensitivities * (ux @ result.sensitivities.T).T  # (m, N)
    var = np.diag(result.covariance)
    groups = (slice(0, n * n_axes), par, slice(e0, size))
    shares = {
        name: np.where(var > 0, full[:, sl].sum(axis=1) / np.where(var > 0, var, 1.0), 0.0)
        for name, sl in zip(GROUPS, groups, strict=True)
    }
    u_q = c_points @ ux @ c_points.T
    return TaskResult(result, points, 0.5 * (u_q + u_q.T), shares)


def _psd(matrix, shape: tuple[int, ...], what: str) -> np.ndarray:
    m = np.asarray(matrix, float)
    if m.shape != shape or not np.all(np.isfinite(m)):
        raise InputError(f"{what}: expected finite values of shape {shape}, got {m.shape}")
    if not np.allclose(m, np.swapaxes(m, -1, -2), rtol=1e-10, atol=0):
        raise InputError(f"{what}: not symmetric")
    low = np.linalg.eigvalsh(m).min(axis=-1)
    scale = np.abs(m).max(axis=(-1, -2))
    if np.any(low < -1e-10 * np.maximum(scale, np.finfo(float).tiny)):
        raise InputError(
            f"{what}: not positive semidefinite (smallest eigenvalue {float(np.min(low)):.3g})"
        )
    return m
