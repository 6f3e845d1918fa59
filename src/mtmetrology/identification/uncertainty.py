"""Uncertainty of an identification: GUF through the full Jacobian, Monte Carlo that
re-solves it in every trial, and their JCGM 102 validation.

Any observation model, any machine
----------------------------------
The measurement model is ``x̂ = x̂(z)``: the solution of a weighted least-squares
identification as a function of its inputs z (readings, artefact lengths, the values of
priors).  The identification engine needs from the *problem* (for instance a
:class:`~mtmetrology.identification.BallCentreProblem`; a tracker or multilateration
problem exposes the same four methods):

- ``input_jacobian(x) -> (n_rows, N)``: ∂r/∂z of the weighted residuals;
- ``residuals_batch(X (K, n), Z (K, N)) -> (K, n_rows)``: residuals of K copies, each with
  its own unknowns and inputs (one vectorised call per chunk of Monte Carlo trials);
- ``with_inputs(z)``: the same problem with inputs z, whose ``evaluate(x) -> (r, J)`` the
  full Gauss–Newton fallback solves;
- optionally ``input_estimate() -> (N,)``: its own inputs z₀; with it the Monte Carlo
  trials start at a linear prediction (below), without it at the solution;

and from the converged *result* (an
:class:`~mtmetrology.identification.IdentificationResult`) its ``estimate``, ``jacobian``
and ``names``.  The inputs' joint distribution is an
:class:`~mtmetrology.uncertainty.InputSet` in the order of z (the application states how
it is made: probing noise, a repeatability model, campaigns).  The outputs are all
unknowns in internal units (mm, rad), a chosen subset of them, or, given a
:class:`~mtmetrology.kinematics.Machine`, its error parameters in customary units (µm, µrad,
µm/m).

GUF (JCGM 102:2011, 6.2.2; Alami Mchichi (2018) eq. 5.15)
----------------------------------------------------------
At the solution the normal equations ``Jᵀ r(x̂, z) = 0`` hold; implicit differentiation
gives the sensitivities of *all* unknowns::

    C = ∂x̂/∂z = −J⁺ ∂r/∂z,      U_x = C U_z Cᵀ

with J the full weighted Jacobian; the rows of the outputs are kept, which marginalises the
nuisance unknowns (ball centres, tool, station poses) without changing the statistics of
the outputs (Sepahi Boroujeni (2021) Ch. 5).  With U_z = σ² I this is ``(JᵀJ)⁻¹``.

Monte Carlo (JCGM 101:2008, JCGM 102:2011 §7)
---------------------------------------------
Every trial draws z and re-solves the identification to convergence with the exact
residuals (not a linearisation): each trial starts at the GUF's linear prediction
``x̂ + C (z − z₀)`` (C as above; at x̂ for a problem without ``input_estimate``) and
iterates ``x ← x − J₀⁺ r(x; z)`` with the factorised Jacobian J₀ of the solution
(:func:`mtmetrology.optimize.chord_batch`); a trial the chord does not converge is
re-solved by full Gauss–Newton.  The start only saves iterations (the chord's first step
from x̂ is, to first order in z − z₀, that prediction): at µm-level noise one exact
evaluation per trial then meets the tolerance.  Fixed M or the adaptive procedure
(JCGM 101 §7.9, JCGM 102 §7.8); chunks draw independent streams of one SeedSequence, so
the result does not depend on the executor.

Threads and processes
---------------------
A chunk's matrices are small (a few hundred residual rows, tens of unknowns, 2 000 trials):
the model evaluates them with one BLAS thread (:func:`mtmetrology._backend.one_thread`),
and so do the GUF and the Monte Carlo statistics; the cores are used through the
executor's processes.  On idle cores multi-threaded OpenBLAS gains nothing here (10⁵
trials in-process: 1.52 s median at 2 BLAS threads, 1.62 s at 1); when another process
keeps a core busy its threads wait on each other: at load 8–11 on 2 cores, 10.2 s against
2.4 s, and the 84 × 84 eigendecomposition of the 84-parameter model's output covariance
0.35 s against milliseconds (bench/bench_samba.py ``--before``).

Joint coverage
--------------
The p hyper-ellipsoid of m normal outputs has ``k_p = sqrt(χ²_m(p))`` (JCGM 102:2011,
6.5.2.3): 4.73 for m = 13, as Sepahi Boroujeni (2021) Table 5-3 reports.  Alami Mchichi
(2018) eq. 5.18 uses ``k_q = 3.12–3.15`` (13-parameter model) and 3.49 (84): these are the
Bonferroni hyper-rectangle factors ``Φ⁻¹(1 − 0.05/(2n))`` over *all* n unknowns (n = 28–31
with balls and tool; n = 102–105), not the region of the m parameters
(:func:`joint_coverage` reports both, each named).

References
----------
JCGM 101:2008, *Evaluation of measurement data — Supplement 1 to the GUM — Propagation of
distributions using a Monte Carlo method*, §7.9.
JCGM 102:2011, *Evaluation of measurement data — Supplement 2 to the GUM — Extension to any
number of output quantities*, §6.2, §6.5, §7.7, §7.8, §8.
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, Ch. 5, Tables 5-2, 5-3.
Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes ...*. PhD thesis,
École Polytechnique de Montréal, eqs 5.15–5.18.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mtmetrology._backend import one_thread
from mtmetrology.errors import ConvergenceError, InputError
from mtmetrology.optimize import chord_batch, least_squares
from mtmetrology.rng import SeedLike
from mtmetrology.uncertainty import GUFResult, InputSet, MCMResult, monte_carlo, validate_guf
from mtmetrology.uncertainty import guf as guf_propagate
from mtmetrology.uncertainty.mcm import NumericalTolerance, numerical_tolerance
from mtmetrology.uncertainty.regions import (
    normal_ellipsoidal_coverage_factor,
    normal_rectangular_coverage_factor,
)
from mtmetrology.uncertainty.validation import ValidationReport

__all__ = [
    "IdentificationModel",
    "identification_guf",
    "identification_mcm",
    "input_sensitivities",
    "joint_coverage",
    "unknowns_covariance",
    "validate_identification",
]

#: Trials per call of the model: bounds the (trial, row) arrays to a few MB.
CHUNK_TRIALS = 2_000


def input_sensitivities(problem, result) -> np.ndarray:
    """C = ∂x̂/∂z (n_unknowns, N) of all unknowns (internal units) to the inputs.

    ``C = −J⁺ ∂r/∂z`` with the column-scaled pseudo-inverse of the full weighted Jacobian
    (the minimum-norm solution when rank deficient; JCGM 102:2011, 6.2.2).

    Parameters
    ----------
    problem : observation model
        With ``input_jacobian(x)`` (see the module notes).
    result : IdentificationResult
        The converged identification of ``problem``.
    """
    return _sensitivities(problem, result.estimate, result.jacobian)


def _sensitivities(problem, x: np.ndarray, jac: np.ndarray) -> np.ndarray:
    jz = problem.input_jacobian(x)  # (n_rows, N)
    norms = np.linalg.norm(jac, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    return -np.linalg.pinv(jac / norms, rcond=1e-8) @ jz / norms[:, None]


def unknowns_covariance(problem, result, inputs: InputSet) -> np.ndarray:
    """GUF covariance ``U_x = C U_z Cᵀ`` (n_unknowns, n_unknowns) of *all* unknowns,
    internal units (mm, rad), in the order of ``result.names``.

    Parameters
    ----------
    problem : observation model
    result : IdentificationResult
    inputs : InputSet
        The inputs z of ``problem`` (in the order of its ``input_jacobian`` columns).
    """
    sens = input_sensitivities(problem, result)
    return sens @ inputs.covariance @ sens.T


class IdentificationModel:
    """The identification as a measurement model: inputs z (M, N) -> outputs (M, m).

    Picklable (process pools and Dask ship it to the workers).

    Parameters
    ----------
    problem : observation model
        ``residuals_batch``, ``with_inputs`` and ``input_jacobian`` (module notes).
    result : IdentificationResult
        The converged identification (its estimate and Jacobian start every trial).
    machine : Machine, optional
        Outputs are the machine's error parameters in customary units (µm, µrad, µm/m).
    outputs : sequence of str, optional
        Without ``machine``: the unknowns reported (default all), internal units.
    xtol : float
        Stop when the scaled chord step is below ``xtol`` (units of the input standard
        uncertainties); that last step is applied too, so each unknown ends within about
        ``ρ·xtol·u`` of its fixed point, ρ ≈ 1e-4 the contraction rate of the chord at
        µm-level noise.  Trials start at the linear prediction ``x̂ + C (z − z₀)``, so one
        exact evaluation (a check and its small step) usually suffices.
    max_iter : int
        Chord steps per trial before the full Gauss–Newton fallback.

    Attributes
    ----------
    index : (m,) int ndarray
        Positions of the outputs among the unknowns.
    scales : (m,) ndarray
        Internal units per output unit (an output is ``x[index] / scales``).
    output_names, output_units : tuple of str

    Raises
    ------
    InputError
        If an output is not an unknown of the identification.
    """

    def __init__(
        self,
        problem,
        result,
        *,
        machine=None,
        outputs: Sequence[str] | None = None,
        xtol: float = 1e-3,
        max_iter: int = 20,
    ):
        names = list(result.names)
        if machine is not None:
            outputs, scales = machine.parameter_names, machine.parameter_scales
            units = tuple(machine.parameter_units)
        else:
            outputs = tuple(names if outputs is None else outputs)
            scales, units = np.ones(len(outputs)), ("",) * len(outputs)
        missing = [n for n in outputs if n not in names]
        if missing:
            raise InputError(f"output {missing[0]!r} is not an unknown of the identification")
        self.problem = problem
        self.x0 = result.estimate
        self.jacobian0 = result.jacobian
        # C = ∂x̂/∂z (n_unknowns, N): with z₀ known every trial starts at x̂ + C (z − z₀)
        with one_thread():
            self.all_sensitivities = _sensitivities(problem, self.x0, self.jacobian0)
        estimate = getattr(problem, "input_estimate", None)
        self.z0 = None if estimate is None else np.asarray(estimate(), dtype=float)
        self.index = np.array([names.index(n) for n in outputs], dtype=int)
        self.scales = np.asarray(scales, dtype=float)
        self.output_names = tuple(outputs)
        self.output_units = units
        self.xtol = float(xtol)
        self.max_iter = int(max_iter)
        self.rank_rtol = 1e-8

    def sensitivities(self) -> np.ndarray:
        """∂y/∂z (m, N) of the outputs (output units per input unit)."""
        return self.all_sensitivities[self.index] / self.scales[:, None]

    def solve(self, z: np.ndarray) -> np.ndarray:
        """All unknowns (M, n_unknowns), internal units, for inputs z (M, N), with one BLAS
        thread (module notes)."""
        with one_thread():
            return self._solve(np.atleast_2d(np.asarray(z, dtype=float)))

    def _solve(self, z: np.ndarray) -> np.ndarray:
        if self.z0 is None:
            start = np.broadcast_to(self.x0, (z.shape[0], self.x0.size))
        else:
            start = self.x0 + (z - self.z0) @ self.all_sensitivities.T
        res = chord_batch(
            lambda x, idx: self.problem.residuals_batch(x, z[idx]),
            start,
            self.jacobian0,
            xtol=self.xtol,
            max_iter=self.max_iter,
            rank_rtol=self.rank_rtol,
            apply_final_step=True,
        )
        x = res.x
        for trial in np.flatnonzero(~res.success):
            x[trial] = self._full_solve(z[trial])
        return x

    def __call__(self, z: np.ndarray) -> np.ndarray:
        """Outputs (M, m) in output units for inputs (M, N); (m,) for (N,)."""
        y = self.solve(z)[:, self.index] / self.scales
        return y[0] if np.ndim(z) == 1 else y

    def _full_solve(self, z: np.ndarray) -> np.ndarray:
        """Gauss–Newton with the exact Jacobian for one trial the chord did not converge."""
        trial = self.problem.with_inputs(z)
        res = least_squares(
            lambda x: trial.evaluate(x), self.x0, xtol=1e-8, rank_rtol=self.rank_rtol
        )
        if not res.success:
            raise ConvergenceError(
                f"a Monte Carlo trial of the identification did not converge ({res.message}); "
                "the input uncertainties are too large for the model's linear range"
            )
        return res.x


def identification_guf(model: IdentificationModel, inputs: InputSet, p: float = 0.95) -> GUFResult:
    """GUF of the outputs of an identification through its full Jacobian.

    Parameters
    ----------
    model : IdentificationModel
    inputs : InputSet
        The inputs z with their joint distribution.
    p : float
        Coverage probability.

    Returns
    -------
    GUFResult
        Outputs named and in the units of ``model``.

    Notes
    -----
    ``C = −J⁺ ∂r/∂z`` over all unknowns, the output rows kept (module notes);
    ``U_y = C U_z Cᵀ`` (JCGM 102:2011, 6.2.2).
    """
    sens = model.sensitivities()
    with one_thread():
        return guf_propagate(
            model,
            inputs,
            jacobian=lambda z: sens,
            p=p,
            output_names=model.output_names,
            output_units=model.output_units,
        )


def identification_mcm(
    model: IdentificationModel,
    inputs: InputSet,
    *,
    trials: int | None = None,
    adaptive: bool = False,
    digits: int = 2,
    tolerance=None,
    seed: SeedLike = None,
    executor=None,
    p: float = 0.95,
    chunk_size: int = CHUNK_TRIALS,
    sequence_size: int = 10_000,
    keep_samples: bool = False,
    progress=None,
) -> MCMResult:
    """Monte Carlo of the outputs of an identification, re-solving it in every trial.

    Parameters
    ----------
    model : IdentificationModel
    inputs : InputSet
    trials : int, optional
        Fixed number of trials (10⁵ when neither this nor ``adaptive`` is given).
    adaptive : bool
        JCGM 101 §7.9 / JCGM 102 §7.8 adaptive procedure.
    digits : int
        Significant digits of the standard uncertainties the adaptive run stabilises.
    tolerance : float, array or NumericalTolerance, optional
        Explicit numerical tolerances (output units).
    seed : int, SeedSequence or Generator
    executor : None, str, int or executor object
        See :func:`mtmetrology.uncertainty.executors.resolve_executor`.
    p : float
    chunk_size : int
        Trials per model call; part of what the random streams depend on.
    sequence_size : int
        Trials per sequence of the adaptive procedure (JCGM 101 7.9.4 recommends 10⁴).
    keep_samples : bool
    progress : callable, optional
        ``progress(done, total)`` as the trials are evaluated
        (:func:`~mtmetrology.uncertainty.mcm.monte_carlo`).

    Returns
    -------
    MCMResult
        In the output units; the same numbers for a given seed on any executor.
    """
    if not adaptive and trials is None:
        trials = 100_000
    with one_thread():  # the statistics too (eigh, products of the samples): module notes
        return monte_carlo(
            model,
            inputs,
            trials=trials,
            adaptive=adaptive,
            digits=digits,
            tolerance=tolerance,
            seed=seed,
            executor=executor,
            p=p,
            chunk_size=chunk_size,
            sequence_size=sequence_size,
            keep_samples=keep_samples,
            output_names=model.output_names,
            output_units=model.output_units,
            progress=progress,
        )


def joint_coverage(m: int, p: float = 0.95) -> dict:
    """Joint coverage factors of m normal outputs, each named (see the module notes).

    Examples
    --------
    >>> c = joint_coverage(13)
    >>> round(c["hyper_ellipsoid"], 2), round(c["hyper_rectangle_bonferroni"], 2)
    (4.73, 2.89)
    """
    return {
        "m": int(m),
        "p": float(p),
        "hyper_ellipsoid": normal_ellipsoidal_coverage_factor(m, p),
        "hyper_rectangle_bonferroni": normal_rectangular_coverage_factor(m, p),
        "note": (
            "hyper_ellipsoid = sqrt(chi2_m(p)) (JCGM 102:2011, 6.5.2.3); Alami Mchichi (2018) "
            "eq. 5.18 uses k_q = 3.12-3.15 (13 parameters) and 3.49 (84), which are the "
            "Bonferroni hyper-rectangle factors over all 28-31 (102-105) unknowns, not "
            "sqrt(chi2_m(0.95))"
        ),
    }


def validate_identification(guf: GUFResult, mcm: MCMResult, digits: int = 2) -> ValidationReport:
    """JCGM 102 §8 validation of the GUF of an identification by its Monte Carlo, per
    output and jointly (largest eigenvalue, hyper-ellipsoid coverage factor).

    δ follows from ``digits`` significant digits of each GUF standard uncertainty
    (JCGM 101:2008, 7.9.2); ρ and κ_p from two digits of the MCM λ_max and k_p.
    """
    delta = numerical_tolerance(guf.standard_uncertainty, digits)
    return validate_guf(
        guf.estimate,
        guf.covariance,
        mcm,
        tolerance=NumericalTolerance(delta),
        p=guf.p,
        guf_coverage_factor=guf.region_coverage_factor,
        names=guf.names,
    )
