"""Ballbar diagnosis as identification: simulate, identify, and say what a second test adds.

The readings of one or several circular tests are the observations of
:class:`~mtmetrology.ballbar.model.BallbarProblem`, solved by the identification engine
(:func:`~mtmetrology.identification.levenberg_marquardt`); the unknowns are the ISO 230-1
parameters of the planes' axes, the dynamic terms and the pivots (nuisance).

Uncertainty.  With a stated reading uncertainty σ the covariance is ``(JᵀJ)⁻¹`` of the
weighted problem under the engine's adequacy rule (scaled by s² when the residuals
contradict σ).  Without one (the usual case: a ballbar's repeatability on a given machine
is not known beforehand) σ is estimated from the residuals, ``s² = ‖r‖²/(m − n)``, and the
covariance is ``s²(JᵀJ)⁻¹`` (JCGM 100:2008, H.3: the measurement model is readings with
independent errors of one common unknown standard deviation).  U = k u with k = 2.

When one plane at one radius cannot separate two parameters, the rank analysis names the
combination, and :func:`second_test_advice` tries each candidate second test (the same
plane at another radius, each other plane at the same radius) on the nominal Jacobian and
lists those that make the problem full rank.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from mtmetrology.ballbar.iso230_4 import circular_results
from mtmetrology.ballbar.model import DYNAMIC_UNITS, BallbarProblem, plane_model
from mtmetrology.ballbar.records import PLANES, BallbarConditions, BallbarTest, nominal_test
from mtmetrology.errors import ConvergenceError, InputError, RankDeficientError
from mtmetrology.identification import (
    IdentificationResult,
    analyse_identifiability,
    levenberg_marquardt,
)
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.rng import SeedLike, as_generator
from mtmetrology.uncertainty.coverage import DEFAULT, DEFAULT_K
from mtmetrology.units import from_internal, to_internal

__all__ = [
    "COVERAGE_FACTOR",
    "KIND",
    "BallbarDiagnosis",
    "BatchDiagnosis",
    "diagnose",
    "diagnose_many",
    "model_machine",
    "second_test_advice",
    "simulate",
]

#: The calibration document of ``mtm ballbar calibrate`` (``iso230-4-circular`` is the
#: ISO 230-4 verification of ``mtm ballbar analyse``): one kind, one history category.
KIND = "iso230-4-calibration"
#: k of the expanded uncertainties U = k u: the coverage policy (EA-4/02: k = 2).
COVERAGE_FACTOR = DEFAULT_K
#: Converged when the scaled step is below a millionth of the reading uncertainty.
XTOL = 1e-6


def model_machine(machine: Machine, tests: Sequence[BallbarTest], parameters=None) -> Machine:
    """The machine with the identified parameters active: ``parameters`` or the union of
    :func:`~mtmetrology.ballbar.model.plane_model` over the tests' planes."""
    if parameters is None:
        parameters = []
        for t in tests:
            parameters += [
                n for n in plane_model(machine, t.conditions.plane) if n not in parameters
            ]
    return machine.with_parameters(list(parameters))


def simulate(
    machine: Machine,
    tests: Sequence[BallbarTest],
    truth: Mapping[str, float],
    *,
    sigma: float = 0.0,
    seed: SeedLike = None,
    spike_decay: float | None = None,
) -> list[BallbarTest]:
    """Readings of a virtual machine (model (1) of :mod:`~mtmetrology.ballbar.model`).

    Parameters
    ----------
    machine : Machine
    tests : sequence of BallbarTest
        Their samples (their readings are replaced).
    truth : mapping
        Name → true value, internal units (mm, rad, s): ISO 230-1 parameters,
        ``servo_mismatch_ab``, ``reversal_spike_a``, ``length offset`` and
        ``pivot <test> a|b`` (the pivot's in-plane coordinates; nominal otherwise).
    sigma : float
        Standard deviation of the reading noise, mm (normal, independent).
    seed : int or Generator, optional

    Returns
    -------
    list of BallbarTest

    Raises
    ------
    InputError
        A name that is not an unknown of the model.
    """
    iso = [n for n in truth if n.startswith("E_")]
    problem = BallbarProblem(
        machine.with_parameters(iso),
        tests,
        length_calibrated="length offset" not in truth,
        sigma=1.0,
        spike_decay=spike_decay,
    )
    x = problem.initial()
    for name, value in truth.items():
        if name not in problem.names:
            raise InputError(f"true value {name!r}: not an unknown of the ballbar model")
        x[problem.names.index(name)] = value
    ell = problem.model(x)
    if sigma > 0:
        ell = ell + as_generator(seed).normal(0.0, sigma, ell.shape)
    out, k = [], 0
    for t in tests:
        out.append(t.with_reading(ell[k : k + len(t)]))
        k += len(t)
    return out


def _candidates(test: BallbarTest) -> list[tuple[str, BallbarConditions]]:
    c = test.conditions
    found = [
        (
            f"the {c.plane} plane at radius {1.5 * c.radius:g} mm",
            replace(c, radius=1.5 * c.radius, name=f"{c.name}+radius"),
        )
    ]
    for plane in PLANES:
        if plane != c.plane:
            found.append(
                (
                    f"the {plane} plane at radius {c.radius:g} mm",
                    replace(c, plane=plane, name=f"{c.name}+{plane}"),
                )
            )
    return found


def second_test_advice(problem: BallbarProblem, parameters: Sequence[str]) -> list[str]:
    """The candidate second tests that make the identification full rank.

    Each candidate (same plane at 1.5 R; each other plane at R, same centre) is added as a
    nominal test, the model re-formed with the parameters of its plane as well, and the
    Jacobian at the nominal point checked for rank.

    Returns
    -------
    list of str
        Descriptions of the tests that separate everything; empty when none does alone.
    """
    found = []
    for text, cond in _candidates(problem.tests[0]):
        extra = nominal_test(cond, 90)
        tests = [*problem.tests, extra]
        m = problem.machine
        names = list(parameters)
        names += [n for n in plane_model(m, cond.plane) if n not in names]
        try:
            trial = BallbarProblem(
                m.with_parameters(names),
                tests,
                dynamic=_dynamic_kinds(problem.dynamic),
                length_calibrated=problem.length_calibrated,
                sigma=1.0,
            )
        except InputError:
            continue  # the machine has no such plane
        _, jac = trial.evaluate(trial.initial())
        if analyse_identifiability(jac, trial.names).full_rank:
            found.append(text)
    return found


def _dynamic_kinds(names: Sequence[str]) -> tuple[str, ...]:
    kinds = []
    if any(n.startswith("servo") for n in names):
        kinds.append("servo")
    if any(n.startswith("reversal_spike") for n in names):
        kinds.append("spike")
    return tuple(kinds)


@dataclass(frozen=True, eq=False)
class BallbarDiagnosis:
    """Result of :func:`diagnose`.

    Attributes
    ----------
    machine : Machine
        With the identified parameters active.
    problem : BallbarProblem
    identification : IdentificationResult
        Its covariance is the one stated (σ given, adequacy rule) or s²(JᵀJ)⁻¹.
    covariance_source : str
    advice : list of str
        Second tests that would separate what this set cannot (empty when full rank).
    """

    machine: Machine
    problem: BallbarProblem = field(repr=False)
    identification: IdentificationResult = field(repr=False)
    covariance_source: str
    advice: list = field(default_factory=list)

    @property
    def names(self) -> tuple[str, ...]:
        return self.identification.names

    def value(self, name: str) -> float:
        """Identified value of an unknown, internal units."""
        return self.identification.value(name)

    def u(self, name: str) -> float:
        """Standard uncertainty of an unknown, internal units."""
        return self.identification.u(name)

    def units(self) -> list[str]:
        """Display unit of every unknown."""
        out = list(self.machine.parameter_units)
        for n in self.names[self.machine.n_params :]:
            kind = "servo_mismatch" if n.startswith("servo") else "reversal_spike"
            out.append(DYNAMIC_UNITS[kind])
        return out

    def parameter_rows(self) -> list[dict]:
        """``[{name, value, unit, u, U, k}]`` in display units (nuisance included)."""
        scales = self.problem.scales()
        ident = self.identification
        u = ident.standard_uncertainty
        rows = []
        for i, (name, unit) in enumerate(zip(self.names, self.units(), strict=True)):
            ui = None if ident.minimum_norm else float(u[i] / scales[i])
            rows.append(
                {
                    "name": name,
                    "value": float(ident.estimate[i] / scales[i]),
                    "unit": unit,
                    "u": ui,
                    "U": None if ui is None else COVERAGE_FACTOR * ui,
                    "k": COVERAGE_FACTOR,
                    "nuisance": name in self.problem.nuisance,
                }
            )
        return rows

    def parameter_set(self) -> ParameterSet:
        """The ISO 230-1 parameters with their covariance block (the dynamic terms and the
        pivots dropped, :meth:`IdentificationResult.parameter_set`): what combines with the
        laser runs and other calibrations of the machine
        (:func:`~mtmetrology.identification.combine.combine_parameter_sets`)."""
        return self.identification.parameter_set(
            self.machine, {"source": "ISO 230-4 ballbar tests"}
        )

    def to_dict(self, machine_name: str | None = None) -> dict:
        """The result document (``kind: iso230-4-calibration``): ``parameters`` and
        ``covariance`` are the ISO 230-1 parameters as a parameter set (``mtm export``,
        ``mtm predict`` and ``mtm history add`` read them), ``estimates`` every unknown
        with U and k (the dynamic terms and the nuisance pivots too)."""
        from mtmetrology.kinematics.conventions import describe_parameters

        ident = self.identification
        diag = ident.diagnostics
        scales = self.problem.scales()
        cov = ident.covariance / np.outer(scales, scales)
        res_um = from_internal(ident.residuals * self.problem.sigma, "µm")
        per_test, k = [], 0
        for t in self.problem.tests:
            r = res_um[k : k + len(t)]
            k += len(t)
            per_test.append(
                {
                    "conditions": t.conditions.to_dict(),
                    "source": t.source,
                    "samples": len(t),
                    "iso230_4": circular_results(t).to_dict(),
                    "residual_rms_um": {
                        d: float(np.sqrt(np.mean(r[t.direction == s] ** 2)))
                        for d, s in (("ccw", 1), ("cw", -1))
                    },
                }
            )
        return {
            "kind": KIND,
            "version": 1,
            "machine": machine_name or self.machine.name,
            "category": "calibration",
            **ident.parameter_set_keys(self.machine, {"source": "ISO 230-4 ballbar tests"}),
            "estimates": self.parameter_rows(),
            "estimate_covariance": {"names": list(self.names), "matrix": cov.tolist()},
            "covariance_source": self.covariance_source,
            "coverage": DEFAULT.to_dict(),
            "conventions": [c.to_dict() for c in describe_parameters(self.machine)],
            "dynamic_conventions": _DYNAMIC_CONVENTIONS,
            "identification": {
                "message": ident.message,
                "success": ident.success,
                "minimum_norm": ident.minimum_norm,
                "rank": diag.rank,
                "unknowns": len(self.names),
                "condition_scaled": float(diag.condition_scaled)
                if np.isfinite(diag.condition_scaled)
                else None,
                "confounded": [list(g) for g in diag.confounded()],
                "dof": ident.dof,
                "variance_factor": ident.variance_factor,
            },
            "second_test_advice": self.advice,
            **({} if ident.adequacy is None else {"adequacy": ident.adequacy.to_dict()}),
            "tests": per_test,
        }


_DYNAMIC_CONVENTIONS = {
    "servo_mismatch_ab": "τ, ms: axis b lags axis a by τ; tool displaced by −τ·v_b along b",
    "reversal_spike_a": "A, µm: at each reversal of axis a the tool lags by A behind the new "
    "sense of motion of a, decaying as exp(−Δφ/φ₀) with the arc Δφ after the reversal",
    "length offset": "L, µm: the bar reads R + L at zero deviation (uncalibrated length)",
    "pivot <test> a|b": "pivot position in the plane, workpiece frame, µm from the origin",
}


def diagnose(
    machine: Machine,
    tests: Sequence[BallbarTest],
    *,
    parameters: Sequence[str] | None = None,
    dynamic: Sequence[str] = ("servo", "spike"),
    length_calibrated: bool = True,
    sigma: float | None = None,
    adequacy: str = "scale",
    minimum_norm: bool = False,
    spike_decay: float | None = None,
) -> BallbarDiagnosis:
    """Identify the ISO 230-1 errors and dynamic terms of the planes from ballbar tests.

    Parameters
    ----------
    machine : Machine
    tests : sequence of BallbarTest
        Identified together (planes, radii).
    parameters : sequence of str, optional
        ISO 230-1 names; the planes' models (:func:`model_machine`) by default.
    dynamic : sequence of {"servo", "spike"}
    length_calibrated : bool
        The bar's length is known; else a ``length offset`` unknown.
    sigma : float, optional
        Standard uncertainty of one reading, mm; estimated from the residuals if omitted.
    adequacy : {"scale", "a-priori"}
        The engine's rule when σ is stated.
    minimum_norm : bool
        Return a flagged minimum-norm solution of a rank-deficient set instead of refusing.
    spike_decay : float, optional
        φ₀ of the reversal spikes, rad.

    Returns
    -------
    BallbarDiagnosis

    Raises
    ------
    RankDeficientError
        Naming what the tests cannot separate and which second test would.
    ConvergenceError
        If the iteration stops without converging.
    """
    m = model_machine(machine, tests, parameters)
    weight = sigma if sigma is not None else float(to_internal(1.0, "µm"))
    problem = BallbarProblem(
        m,
        tests,
        dynamic=dynamic,
        length_calibrated=length_calibrated,
        sigma=weight,
        spike_decay=spike_decay,
    )
    report = [*m.parameter_names, *problem.dynamic]
    try:
        result = levenberg_marquardt(
            problem, xtol=XTOL, report_names=report, minimum_norm=minimum_norm
        )
    except RankDeficientError as err:
        groups = [g for g in err.confounded if set(g) & set(report)] or list(err.confounded)
        advice = second_test_advice(problem, m.parameter_names)
        listed = "; ".join(" ~ ".join(g) for g in groups)
        hint = ("add " + " or ".join(advice)) if advice else "no single second test separates them"
        raise RankDeficientError(
            f"the ballbar tests cannot separate {listed}: {hint}; or drop one parameter of "
            "each group (--params), or ask for the minimum-norm solution (--min-norm)",
            confounded=tuple(groups),
        ) from None
    if not result.success:
        raise ConvergenceError(f"the ballbar identification did not converge ({result.message})")
    if sigma is None:
        s2 = result.variance_factor
        if s2 is None:
            raise InputError("no redundancy to estimate the reading uncertainty: give sigma")
        result = replace(result, covariance=result.covariance * s2)
        source = "residuals: s²(JᵀJ)⁻¹, s² = ‖r‖²/(m − n) (JCGM 100:2008, H.3)"
    else:
        result = result.with_adequacy(adequacy)
        source = f"stated σ = {from_internal(sigma, 'µm'):g} µm, adequacy rule {adequacy!r}"
    advice = second_test_advice(problem, m.parameter_names) if result.minimum_norm else []
    return BallbarDiagnosis(m, problem, result, source, advice)


@dataclass(frozen=True)
class BatchDiagnosis:
    """K repeated tests of one geometry identified at once (:func:`diagnose_many`).

    Attributes
    ----------
    names : tuple of str
    estimate : (K, n) ndarray
        Internal units.
    u : (K, n) ndarray
        Standard uncertainties from each test's own residuals, s_k √diag((JᵀJ)⁻¹).
    status : (K,) int ndarray
        :class:`mtmetrology.optimize.Status` of each solve (> 0 converged).
    """

    names: tuple
    estimate: np.ndarray
    u: np.ndarray
    status: np.ndarray


def diagnose_many(problem: BallbarProblem, readings: np.ndarray) -> BatchDiagnosis:
    """Identify K tests of the same samples at once (e.g. repeated virtual tests).

    Every test starts from the problem's nominal point and takes chord (simplified
    Gauss–Newton) steps with the Jacobian there, factorised once
    (:func:`mtmetrology.optimize.chord_batch`); the model is first order in the errors,
    so the chord converges in two or three steps.  Each test's σ is estimated from its
    own residuals, s_k² = ‖r_k‖²/(m − n), and u_k = s_k √diag((JᵀJ)⁻¹) (the same
    measurement model as :func:`diagnose` without a stated σ).

    Parameters
    ----------
    problem : BallbarProblem
        The geometry; its σ only scales the residuals.
    readings : (K, m) ndarray
        ℓ of each test, mm, in the problem's sample order.

    Returns
    -------
    BatchDiagnosis
    """
    from mtmetrology.optimize import chord_batch

    measured = np.atleast_2d(np.asarray(readings, dtype=float))
    if measured.shape[1] != problem.n_rows:
        raise InputError(
            f"readings have {measured.shape[1]} samples; the tests have {problem.n_rows}"
        )
    x0 = problem.initial()
    r0, jac = problem.evaluate(x0)
    # the model at the shared nominal point is the same for every test (only the readings
    # differ): the first chord step costs one evaluation of the chain, not one per test
    r_start = r0[None, :] - (measured - problem.measured) / problem.sigma
    step, *_ = np.linalg.lstsq(jac, -r_start.T, rcond=None)
    solved = chord_batch(
        lambda x, index: problem.residuals_batch(x, measured[index]),
        x0 + step.T,
        jac,
        xtol=XTOL,
        apply_final_step=True,
    )
    # ½‖r‖² at the last evaluated point; the final step (below xtol) changes it at second order
    m, n = jac.shape
    s2 = 2.0 * solved.cost / (m - n)
    unit = np.sqrt(np.diag(np.linalg.pinv(jac.T @ jac)))
    return BatchDiagnosis(problem.names, solved.x, np.sqrt(s2)[:, None] * unit, solved.status)
