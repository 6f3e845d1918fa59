"""Task uncertainty of an on-machine measurement compensated with a calibration.

Measurement model (Sepahi Boroujeni (2021), §6.2, eq. 6-14, with the calibration's
uncertainty carried; derivation in :mod:`mtmetrology.omm.simulator`): the compensated
points and the feature are

    q_s = f(Γ_s, Δ) + E_s,    y = g(q_1, ..., q_n),

with the inputs

* Γ_s, the readings φ_s: probing repeatability v_s (pose-dependent model) and, unless the
  machine is recalibrated for the task, the long-term variation Σ_lt of the parameters
  between the calibration and the task (Populations I–IV, §6.2.2: the readings the
  drifted machine needs to reach the fixed workpiece);
* Δ, the calibration's estimate δ̂ that compensates, with its covariance U_θ (the
  identification's GUF or Monte Carlo result), independent of the readings;
* E_s, the unexplained volumetric errors, 0 with cov(e) (eqs. 6-13 to 6-15).

To first order, with A_s = ∂f/∂q, G_s = ∂f/∂δ and c = ∂g/∂q,

    u²(y) = c [⊕ A_s v_s A_sᵀ + G U_θ Gᵀ + G Σ_lt Gᵀ + I ⊗ cov(e)] cᵀ,

the four terms being the budget groups ``repeatability``, ``calibration``,
``long_term_variation`` and ``unexplained_volumetric_error``; they add exactly to u².
The calibration term does not cancel: the part is probed with the machine as it is and
compensated with δ̂ = Δ + ε, ε ~ (0, U_θ) independent of the probing noise.  (It cancels
only in a simulation that compensates with the parameters that generated the readings.)
In the 1-D example of eqs. 6-8 to 6-12, q = φ(1 + δ̂): u² = v + φ² u²(δ̂).

The model is propagated

* by the GUF (JCGM 102:2011, 6.2.1.3) with the analytic sensitivities
  [c A_s, c G, c], and/or
* by Monte Carlo (JCGM 101:2008 and JCGM 102:2011, adaptive 7.9 / 7.8) with
  x ~ N([φ; δ̂; 0], U_x) through the kinematic model and the feature, vectorised over
  trials: each trial draws the parameters from U_θ independently of the readings; with
  both, the GUF is validated against the Monte Carlo result (JCGM 101:2008, 8;
  JCGM 102:2011, 8).

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
from mtmetrology.omm.notebook import OMMNotebookRepr
from mtmetrology.omm.repeatability_model import RepeatabilityModel
from mtmetrology.omm.simulator import MeasurementModel, TaskInputs, covariance_simulator
from mtmetrology.rng import SeedLike, chunk_generators
from mtmetrology.uncertainty.conformity import ConformityDecision
from mtmetrology.uncertainty.coverage import DEFAULT_P
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
        axis (:meth:`RepeatabilityModel.reading_covariance`).
    """
    factors = pose_factors(machine, readings, approach)
    return model.reading_covariance(factors, machine.axis_names, strict=strict)


@dataclass(frozen=True)
class TaskResult(OMMNotebookRepr):
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
        First-order variance share of each output from each independent source
        (:data:`~mtmetrology.omm.simulator.GROUPS`); they add to 1.
    long_term : {"propagated", "recalibrated", "not given"}
        Whether the long-term variation of the parameters is in the budget.
    decision : ConformityDecision or None
        ISO 14253-1:2017 decision when a tolerance was given (of output ``target``).
    target : int
        Index of the output the tolerance applies to (0: the feature's first).
    source : dict or None
        The files of the request, recorded as ``source`` in the document
        (:func:`~mtmetrology.omm.task_request.task_uncertainty_from_files`).
    machine : str or None
        The machine's name: the document then says what it is (``machine``, ``category``
        "task") for the calibration history.
    """

    method: str
    guf: GUFResult
    mcm: MCMResult | None
    validation: ValidationReport | None
    inputs: TaskInputs
    points: np.ndarray
    points_covariance: np.ndarray
    shares: dict
    long_term: str = "not given"
    decision: ConformityDecision | None = None
    target: int = 0
    source: dict | None = None
    machine: str | None = None

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
        doc["measurement_model"] = {
            "equation": "y = g(f(Γ, Δ) + E); Δ = the calibration's estimate, u(Δ) = U_θ",
            "long_term_variation": self.long_term,
        }
        doc["budget_groups"] = {
            name: {g: float(share[j]) for g, share in self.shares.items()}
            for j, name in enumerate(self.guf.names)
        }
        doc["points"] = {"unit": "mm", "compensated": self.points.tolist()}
        if self.decision is not None:
            doc["decision"] = self.decision.to_dict()
        if self.source is not None:
            doc["source"] = dict(self.source)
        if self.machine is not None:
            doc.update(machine=self.machine, category="task")
        return doc


def task_uncertainty(
    machine: Machine,
    readings: np.ndarray,
    parameters: np.ndarray,
    calibration_covariance: np.ndarray,
    feature,
    *,
    long_term_covariance: np.ndarray | None = None,
    recalibrated: bool = False,
    reading_covariance: np.ndarray | None = None,
    unexplained_covariance: np.ndarray | None = None,
    senses: np.ndarray | None = None,
    p: float = DEFAULT_P,
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
        The calibration's estimate δ̂ that compensates the readings (internal units,
        ``machine.parameter_names`` order).
    calibration_covariance : (P, P) array
        U_θ of δ̂, always propagated (the ``calibration`` group).
    feature : mtmetrology.fitting.features.Feature
        ``value(points (..., n, 3))`` vectorised over trials and
        ``jacobian(points) -> (m, 3n)``.
    long_term_covariance : (P, P) array, optional
        Σ_lt, the variation of the parameters between calibrations (e.g. the covariance
        of :func:`~mtmetrology.identification.long_term.long_term_parameters`): the
        ``long_term_variation`` group; none leaves it out (``long_term = "not given"``).
    recalibrated : bool
        The machine is recalibrated for the task: no long-term term (refused together
        with ``long_term_covariance``).
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
        covariance that is not positive semidefinite, an unknown method or simulator, a
        long-term covariance for a recalibrated machine.
    """
    if method not in METHODS:
        raise InputError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    if recalibrated and long_term_covariance is not None:
        raise InputError(
            "long-term covariance given for a machine recalibrated for the task: give one"
        )
    long_term = (
        "recalibrated"
        if recalibrated
        else ("not given" if long_term_covariance is None else "propagated")
    )
    sim_seed, mc_seed = chunk_generators(seed, 2)  # independent: simulator, Monte Carlo
    inputs = covariance_simulator(
        machine,
        readings,
        parameters,
        calibration_covariance,
        long_term_covariance=long_term_covariance,
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
    var = np.diag(guf_result.covariance)
    shares = {
        name: np.where(var > 0, part / np.where(var > 0, var, 1.0), 0.0)
        for name, part in inputs.group_variances(guf_result.sensitivities).items()
    }
    u_q = c_points @ inputs.covariance @ c_points.T
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
        long_term,
        machine=machine.name,
    )
