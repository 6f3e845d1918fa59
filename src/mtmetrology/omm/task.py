"""Task uncertainty of an on-machine measurement by the full-covariance method.

The inputs of the on-machine measurement function are the long-term axis positions Γ
of every probed point and the machine parameters Δ (Sepahi Boroujeni (2021), §6.2), plus
the unexplained volumetric errors E added to the compensated points (eq. 6-14). Their
covariance U_x comes from the covariance simulator (Populations I–IV, §6.2.2,
:mod:`mtmetrology.omm.simulator`), linearised (default, no sampling noise) or sampled as
in the thesis. The compensated points q_s = f(Γ_s, Δ) + e_s and the feature g(q) are
propagated

* by the GUF (JCGM 102:2011, 6.2.1.3) with the analytic sensitivities
  [G A_s, G G_s, G] (A_s = ∂f/∂q, G_s = ∂f/∂δ, G = the feature's Jacobian), and/or
* by Monte Carlo (JCGM 101:2008 and JCGM 102:2011, adaptive 7.9 / 7.8) with
  x ~ N([φ; δ; 0], U_x) through the kinematic model and the feature, vectorised over
  trials; with both, the GUF is validated against the Monte Carlo result (JCGM 101:2008,
  8; JCGM 102:2011, 8).

To first order the machine-parameter uncertainty cancels: A_s (Γ_s − φ_s) + G_s (Δ − δ)
= Ψ_s − ψ_s, so U_q = blockdiag(A_s v_s A_sᵀ) + I ⊗ cov(e) whatever Σ is, and the
budget's machine-parameter share is zero up to rounding. The parameters enter the
*value* (the compensation), not its first-order uncertainty.

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, ch. 6 and 7.

JCGM 101:2008. *Evaluation of measurement data — Supplement 1 to the GUM — Propagation
of distributions using a Monte Carlo method*, 7.9 and 8.

JCGM 102:2011. *Evaluation of measurement data — Supplement 2 to the GUM — Extension to
any number of output quantities*, 6.2.1.3, 7.8 and 8.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.omm.repeatability import RepeatabilityModel
from mtmetrology.omm.simulator import MeasurementModel, TaskInputs, covariance_simulator
from mtmetrology.rng import SeedLike, chunk_generators
from mtmetrology.uncertainty.conformity import ConformityDecision
from mtmetrology.uncertainty.guf import GUFResult, guf
from mtmetrology.uncertainty.mcm import MCMResult, monte_carlo
from mtmetrology.uncertainty.outputs import result_document
from mtmetrology.uncertainty.validation import ValidationReport, validate_results

__all__ = ["METHODS", "TaskResult", "pose_factors", "reading_covariance", "task_uncertainty"]

METHODS = ("guf", "mcm", "both")


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
    method : {"guf", "mcm", "both"}
        What was asked; ``result`` is the Monte Carlo result when it ran (the reference of
        the validation, JCGM 101:2008, 8), the GUF one otherwise.
    guf : GUFResult
        The first-order propagation over Γ, Δ and E (always computed: it gives the
        budget and costs milliseconds).
    mcm : MCMResult or None
        Monte Carlo over x ~ N(x, U_x) through the kinematic model and the feature.
    validation : ValidationReport or None
        The GUF validated by the Monte Carlo result (``method="both"``).
    inputs : TaskInputs
        x and U_x of the covariance simulator.
    points : (n, 3) ndarray, mm
        Compensated points f(φ_s, δ).
    points_covariance : (3n, 3n) ndarray, mm²
        U_q of the compensated points (first order).
    shares : dict of str to (m,) ndarray
        First-order variance share of each output from the repeatability, the machine
        parameters (zero to first order, see the module notes) and E.
    decision : ConformityDecision or None
        ISO 14253-1:2017 decision when a tolerance was given (first output of ``result``).
    """

    method: str
    guf: GUFResult
    mcm: MCMResult | None
    validation: ValidationReport | None
    inputs: TaskInputs
    points: np.ndarray
    points_covariance: np.ndarray
    shares: dict
    decision: ConformityDecision | None = None

    @property
    def result(self) -> GUFResult | MCMResult:
        """The result whose values are reported: Monte Carlo when it ran, else the GUF."""
        return self.mcm if self.mcm is not None else self.guf

    def to_dict(self) -> dict:
        """``uncertainty-result`` document with the group budget and the decision."""
        doc = result_document(self.guf if self.method != "mcm" else None, self.mcm, self.validation)
        doc["covariance_simulator"] = {
            "method": self.inputs.simulator,
            "draws": self.inputs.draws,
        }
        doc["budget_groups"] = {
            name: {g: float(share[j]) for g, share in self.shares.items()}
            for j, name in enumerate(self.guf.names)
        }
        doc["points"] = {"unit": "mm", "compensated": self.points.tolist()}
        if self.decision is not None:
            doc["decision"] = self.decision.to_dict()
        return doc


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
    method: str = "guf",
    simulator: str = "linear",
    draws: int = 10_000,
    trials: int | None = None,
    digits: int = 2,
    tolerance=None,
    sequence_size: int = 10_000,
    max_trials: int = 10_000_000,
    seed: SeedLike = None,
    executor=None,
) -> TaskResult:
    """Value and uncertainty of a feature measured on the machine (full-covariance method).

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
        ``value(points (..., n, 3))`` vectorised over trials and
        ``jacobian(points) -> (m, 3n)``.
    reading_covariance : (n, n_axes, n_axes) array, optional
        v_s of each reading (e.g. :func:`reading_covariance`); none means perfect
        repeatability.
    unexplained_covariance : (3, 3) array, optional
        cov(e) of the unexplained volumetric errors, mm² (PSD).
    senses : (n, n_axes) array, optional
        Sense of motion per axis.
    p : float
        Coverage probability.
    method : {"guf", "mcm", "both"}
        Propagation; "both" validates the GUF by the Monte Carlo result.
    simulator : {"linear", "sampled"}
        Covariance simulator (:func:`~mtmetrology.omm.simulator.covariance_simulator`).
    draws : int
        Q of the sampled simulator.
    trials : int, optional
        Fixed number of Monte Carlo trials; by default the adaptive procedure (JCGM
        101:2008, 7.9; JCGM 102:2011, 7.8) with ``digits`` or ``tolerance``.
    digits, tolerance, sequence_size, max_trials, executor
        As in :func:`mtmetrology.uncertainty.mcm.monte_carlo` (the thesis: δ = 0.05 µm
        for y and u(y), ρ = κ_p = 0.05, sequences of 10⁴).
    seed : int, SeedSequence or Generator, optional
        Root of the random streams (sampled simulator and Monte Carlo).

    Returns
    -------
    TaskResult

    Raises
    ------
    InputError
        Shapes that do not match the machine, a singular linear-axis Jacobian, a
        covariance that is not positive semidefinite, an unknown method or simulator.
    """
    if method not in METHODS:
        raise InputError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    sim_seed, mc_seed = chunk_generators(seed, 2)  # independent: simulator, Monte Carlo
    inputs = covariance_simulator(
        machine,
        readings,
        parameters,
        parameter_covariance,
        reading_covariance=reading_covariance,
        unexplained_covariance=unexplained_covariance,
        senses=senses,
        simulator=simulator,
        draws=draws,
        seed=sim_seed,
    )
    n, n_axes, n_par = inputs.n_points, inputs.n_axes, inputs.n_params
    ev = inputs.at_estimate
    points, a, g = ev.position, ev.d_axes, ev.d_params  # (n,3), (n,3,n_axes), (n,3,P)
    feature_jac = np.atleast_2d(feature.jacobian(points))  # (m, 3n)
    # ∂q/∂x = [blockdiag(A_s), G stacked, I]: (3n, N)
    c_axes = np.zeros((n, 3, n, n_axes))
    c_axes[np.arange(n), :, np.arange(n), :] = a
    c_points = np.hstack(
        [c_axes.reshape(3 * n, n * n_axes), g.reshape(3 * n, n_par), np.eye(3 * n)]
    )
    model = MeasurementModel(machine, feature, n, senses)
    guf_result = guf(
        model,
        inputs,
        jacobian=lambda _x: feature_jac @ c_points,
        p=p,
        output_names=list(model.output_names),
        output_units=list(model.output_units),
    )
    ux = inputs.covariance
    full = guf_result.sensitivities * (ux @ guf_result.sensitivities.T).T  # (m, N)
    var = np.diag(guf_result.covariance)
    shares = {
        name: np.where(var > 0, full[:, sl].sum(axis=1) / np.where(var > 0, var, 1.0), 0.0)
        for name, sl in inputs.groups.items()
    }
    u_q = c_points @ ux @ c_points.T
    mcm_result = validation = None
    if method != "guf":
        mcm_result = monte_carlo(
            model,
            inputs.input_set(),
            trials=trials,
            adaptive=trials is None,
            digits=digits,
            tolerance=tolerance,
            p=p,
            seed=mc_seed,
            executor=executor,
            sequence_size=sequence_size,
            max_trials=max_trials,
            output_names=list(model.output_names),
            output_units=list(model.output_units),
        )
        if method == "both":
            validation = validate_results(
                guf_result, mcm_result, tolerance=tolerance, digits=digits
            )
    return TaskResult(
        method,
        guf_result,
        mcm_result,
        validation,
        inputs,
        points,
        0.5 * (u_q + u_q.T),
        shares,
    )
