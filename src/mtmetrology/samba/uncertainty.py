"""Uncertainty of SAMBA-identified errors: GUF through the identification and Monte Carlo
that re-solves it for every trial, validated against each other (JCGM 101/102).

Inputs z
--------
The measurement model is ``θ = θ̂(z)``: the identification as a function of its inputs,
the linear readings of every indication (mm) and the calibrated scale-bar length (mm)
(:meth:`~mtmetrology.identification.BallCentreProblem.input_estimate`).  Their covariance
U_z (:func:`indication_inputs`) is one of

- probing noise: σ² on every reading (Alami Mchichi (2018) eq. 5.17; Sepahi Boroujeni
  (2021) Ch. 5);
- a repeatability model: per-axis standard uncertainties u_X, u_Y, u_Z;
- K campaigns of the same test: the sample covariance S of the indications divided by K
  (the identification uses their mean).  S has rank ≤ K − 1, below the 3n readings for
  any practical K, so it cannot be inverted.  It is made usable as Sepahi Boroujeni (2021)
  Ch. 5 does: the *weights* of the identification use the pooled variance
  ``σ̄² = trace(S)/3n`` (full rank), the GUF needs no inverse of U_z (a sandwich), and the
  Monte Carlo draws ``z̄ + Σ_k ζ_k (z_k − z̄)/√(K(K − 1))`` (ζ ~ N(0, 1)), whose
  covariance is exactly S/K;

plus u_L² of the scale-bar length (the artefact file) and, with a prior on the tool
vector, u_t² of each component of its value (Alami Mchichi (2018) §5.3.4: the stylus length
known to 1 mm), so both the GUF and every Monte Carlo trial carry the prior.

GUF (JCGM 102:2011, 6.2.2; Alami Mchichi (2018) eq. 5.15)
----------------------------------------------------------
At the solution the normal equations ``Jᵀ r(x̂, z) = 0`` hold; implicit differentiation
gives the sensitivities of *all* unknowns (machine errors, ball centres, tool)::

    C = ∂x̂/∂z = −J⁺ ∂r/∂z,      U_x = C U_z Cᵀ

with J the full weighted Jacobian; the machine-error block of U_x is the marginal
covariance of the errors (the nuisance unknowns are marginalised by dropping their rows,
which leaves the statistics of the errors unchanged: Sepahi Boroujeni (2021) Ch. 5).
With U_z = σ² I this is ``(JᵀJ)⁻¹`` of the weighted problem.

Monte Carlo (JCGM 101:2008, JCGM 102:2011 §7)
---------------------------------------------
Every trial draws z from its distribution and re-solves the identification to
convergence with the exact residuals (not a linearisation): all trials of a chunk start
at the converged solution and iterate ``x ← x − J₀⁺ r(x; z)`` with the factorised Jacobian
J₀ of the solution (:func:`mtmetrology.optimize.chord_batch`), the residuals of every
(trial, indication) pair coming from one call of the kinematic engine; convergence is
checked per trial and a trial the chord does not converge is re-solved by full
Gauss–Newton.  Fixed M or the adaptive procedure (JCGM 101 §7.9, JCGM 102 §7.8); chunks
draw independent streams of one SeedSequence, so the result does not depend on the
executor.

Joint coverage
--------------
The 95 % hyper-ellipsoid of the m error parameters has ``k_p = sqrt(χ²_m(0.95))``
(JCGM 102:2011, 6.5.2.3): 4.73 for m = 13, as Sepahi Boroujeni (2021) Table 5-3 reports.
Alami Mchichi (2018) eq. 5.18 uses ``k_q = 3.12–3.15`` (13-parameter model) and 3.49
(84): these are not √χ²_m(0.95); they are the Bonferroni hyper-rectangle factors
``Φ⁻¹(1 − 0.05/(2n))`` over *all* n unknowns (n = 28–31 with balls and tool; n = 102–105),
which cover the unknowns jointly with at least 95 % but are not the region of the m
parameters.  The result reports ``sqrt(χ²_m(p))`` (GUF), the sample k_p (MCM) and the
Bonferroni factor of the m parameters, each named.

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

from dataclasses import dataclass, field

import numpy as np

from mtmetrology.errors import ConvergenceError, InputError
from mtmetrology.identification import BallCentreProblem
from mtmetrology.optimize import chord_batch, least_squares
from mtmetrology.rng import SeedLike
from mtmetrology.samba.calibrate import SambaCalibration
from mtmetrology.samba.notebook import SambaNotebookRepr
from mtmetrology.uncertainty import (
    GUFResult,
    InputQuantity,
    InputSet,
    MCMResult,
    Normal,
    monte_carlo,
    validate_guf,
)
from mtmetrology.uncertainty import guf as guf_propagate
from mtmetrology.uncertainty.mcm import Tolerance, numerical_tolerance
from mtmetrology.uncertainty.regions import (
    normal_ellipsoidal_coverage_factor,
    normal_rectangular_coverage_factor,
)
from mtmetrology.uncertainty.validation import ValidationReport

__all__ = [
    "IdentificationModel",
    "SambaUncertainty",
    "evaluate_uncertainty",
    "identification_guf",
    "identification_mcm",
    "indication_inputs",
    "input_sensitivities",
    "joint_coverage",
    "pooled_sigma",
    "unknowns_covariance",
    "validate",
]

#: Trials per call of the model: bounds the (trial, indication) arrays to a few MB.
CHUNK_TRIALS = 2_000


def pooled_sigma(campaigns: np.ndarray) -> float:
    """σ̄ = sqrt(trace(S)/3n) of K campaigns (K, n, 3): the full-rank weight, mm."""
    k = campaigns.shape[0]
    dev = campaigns - campaigns.mean(axis=0)
    return float(np.sqrt(np.sum(dev**2) / ((k - 1) * dev[0].size)))


def indication_inputs(
    problem: BallCentreProblem,
    *,
    noise: float | None = None,
    repeatability: tuple[float, float, float] | None = None,
    campaigns: np.ndarray | None = None,
    campaign_mean: bool = True,
) -> InputSet:
    """The inputs z of the identification with their joint distribution.

    Parameters
    ----------
    problem : BallCentreProblem
    noise : float, optional
        Standard uncertainty of every linear reading, mm.
    repeatability : (3,) floats, optional
        Standard uncertainties of the X, Y, Z readings, mm.
    campaigns : (K, n, 3) ndarray, optional
        Readings of K campaigns (the problem's readings are their mean).
    campaign_mean : bool
        With campaigns: the covariance of their mean, S/K (the parameters' u is that of
        the K-campaign mean), or False: S, the covariance of one run (Sepahi Boroujeni
        (2021), Table 5-2 gives one run's u; that of the mean of k runs is u/√k).

    Returns
    -------
    InputSet
        Normal inputs in mm, the bar lengths and the tool prior's value with their u.

    Raises
    ------
    InputError
        If not exactly one source is given.
    """
    given = [v is not None for v in (noise, repeatability, campaigns)]
    if sum(given) != 1:
        raise InputError(
            "give exactly one indication uncertainty: probing noise, a repeatability model "
            "or K campaigns"
        )
    names = problem.input_names()
    z = problem.input_estimate()
    n = problem.readings.shape[0]
    others_u = problem.input_uncertainties()  # scale bars, tool prior
    if campaigns is not None:
        k = campaigns.shape[0]
        dev = (campaigns - campaigns.mean(axis=0)).reshape(k, -1)
        cov = np.zeros((z.size, z.size))
        # S/K, the covariance of the mean, or S, that of one run
        cov[: 3 * n, : 3 * n] = dev.T @ dev / ((k - 1) * (k if campaign_mean else 1))
        cov[3 * n :, 3 * n :] = np.diag(np.square(others_u))
        return InputSet.from_covariance(names, z, cov, units=["mm"] * z.size)
    u = np.full(3 * n, noise) if noise is not None else np.tile(repeatability, n)
    u = np.concatenate([u, others_u])
    if np.any(u <= 0) or not np.all(np.isfinite(u)):
        raise InputError("the indication standard uncertainties must be positive and finite")
    return InputSet(
        [InputQuantity(nm, Normal(x, s), "mm") for nm, x, s in zip(names, z, u, strict=True)]
    )


class IdentificationModel:
    """The identification as a measurement model for Monte Carlo: z (M, N) -> θ (M, m).

    Picklable (process pools and Dask ship it to the workers).

    Parameters
    ----------
    calibration : SambaCalibration
        The converged identification (its estimate and Jacobian start every trial).
    xtol : float
        Stop when the scaled chord step is below ``xtol`` (units of the input standard
        uncertainties); that last step is applied too, so each unknown ends within about
        ``ρ·xtol·u`` of its fixed point, ρ ≈ 1e-4 the contraction rate of the chord at
        µm-level noise: one step and one check per trial.
    max_iter : int
        Chord steps per trial before the full Gauss–Newton fallback.

    Attributes
    ----------
    output_names, output_units : tuple of str
        The machine's error parameters and their customary units (µm, µrad, µm/m).
    """

    def __init__(self, calibration: SambaCalibration, xtol: float = 1e-3, max_iter: int = 20):
        ident = calibration.identification
        self.problem = calibration.problem
        self.x0 = ident.estimate
        self.jacobian0 = ident.jacobian
        self.index = calibration.parameter_indices()
        self.scales = calibration.machine.parameter_scales
        self.output_names = calibration.machine.parameter_names
        self.output_units = calibration.machine.parameter_units
        self.xtol = float(xtol)
        self.max_iter = int(max_iter)
        self.rank_rtol = 1e-8

    def solve(self, z: np.ndarray) -> np.ndarray:
        """All unknowns (M, n_unknowns), internal units, for inputs z (M, N)."""
        z = np.atleast_2d(np.asarray(z, dtype=float))
        start = np.broadcast_to(self.x0, (z.shape[0], self.x0.size))
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
        """Error parameters (M, m) in customary units for inputs (M, N); (m,) for (N,)."""
        theta = self.solve(z)[:, self.index] / self.scales
        return theta[0] if np.ndim(z) == 1 else theta

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


def input_sensitivities(calibration: SambaCalibration) -> np.ndarray:
    """C = ∂x̂/∂z (n_unknowns, n_inputs) of all unknowns (internal units) to the inputs (mm).

    ``C = −J⁺ ∂r/∂z`` with the column-scaled pseudo-inverse of the full weighted Jacobian
    (the minimum-norm solution when rank deficient; JCGM 102:2011, 6.2.2).
    """
    ident = calibration.identification
    jz = calibration.problem.input_jacobian(ident.estimate)  # (m_rows, N)
    jac = ident.jacobian
    norms = np.linalg.norm(jac, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    return -np.linalg.pinv(jac / norms, rcond=1e-8) @ jz / norms[:, None]


def unknowns_covariance(calibration: SambaCalibration, inputs: InputSet) -> np.ndarray:
    """GUF covariance ``U_x = C U_z Cᵀ`` (n_unknowns, n_unknowns) of *all* unknowns
    (machine errors, ball centres, tool), internal units (mm, rad).

    Parameters
    ----------
    calibration : SambaCalibration
    inputs : InputSet
        From :func:`indication_inputs`.

    Returns
    -------
    ndarray, shape (n_unknowns, n_unknowns)
        In the order of ``calibration.identification.names``.
    """
    sens = input_sensitivities(calibration)
    return sens @ inputs.covariance @ sens.T


def identification_guf(
    calibration: SambaCalibration, inputs: InputSet, p: float = 0.95
) -> GUFResult:
    """GUF of the machine errors through the full identification Jacobian.

    Parameters
    ----------
    calibration : SambaCalibration
    inputs : InputSet
        From :func:`indication_inputs`.
    p : float
        Coverage probability.

    Returns
    -------
    GUFResult
        Outputs in customary units (µm, µrad, µm/m), named after the parameters.

    Notes
    -----
    ``C = −J⁺ ∂r/∂z`` over all unknowns, the machine-error rows kept (see the module
    notes); ``U_θ = C U_z Cᵀ`` (JCGM 102:2011, 6.2.2).
    """
    sens_all = input_sensitivities(calibration)
    index = calibration.parameter_indices()
    scales = calibration.machine.parameter_scales
    sens = sens_all[index] / scales[:, None]
    model = IdentificationModel(calibration)
    return guf_propagate(
        model,
        inputs,
        jacobian=lambda z: sens,
        p=p,
        output_names=model.output_names,
        output_units=model.output_units,
    )


def identification_mcm(
    calibration: SambaCalibration,
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
) -> MCMResult:
    """Monte Carlo of the machine errors, re-solving the identification in every trial.

    Parameters
    ----------
    calibration : SambaCalibration
    inputs : InputSet
        From :func:`indication_inputs`.
    trials : int, optional
        Fixed number of trials (10⁵ when neither this nor ``adaptive`` is given).
    adaptive : bool
        JCGM 101 §7.9 / JCGM 102 §7.8 adaptive procedure (sequences of 10⁴ trials).
    digits : int
        Significant digits of the standard uncertainties the adaptive run stabilises.
    tolerance : float, array or Tolerance, optional
        Explicit numerical tolerances (customary units).
    seed : int, SeedSequence or Generator
    executor : None, str, int or executor object
        See :func:`mtmetrology.uncertainty.executors.resolve_executor`.
    p : float
    chunk_size : int
        Trials per model call; part of what the random streams depend on.
    sequence_size : int
        Trials per sequence of the adaptive procedure (JCGM 101 7.9.4 recommends 10⁴).
    keep_samples : bool

    Returns
    -------
    MCMResult
        In customary units; the same numbers for a given seed on any executor.
    """
    if not adaptive and trials is None:
        trials = 100_000
    return monte_carlo(
        IdentificationModel(calibration),
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
        output_names=IdentificationModel(calibration).output_names,
        output_units=IdentificationModel(calibration).output_units,
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


@dataclass(frozen=True, eq=False)
class SambaUncertainty(SambaNotebookRepr):
    """GUF and/or MCM of the identified errors, with the JCGM 102 validation when both ran.

    Attributes
    ----------
    source : str
        "noise", "repeatability" or "campaigns": where U_z came from.
    guf : GUFResult or None
    mcm : MCMResult or None
    validation : ValidationReport or None
    """

    source: str
    guf: GUFResult | None = field(default=None, repr=False)
    mcm: MCMResult | None = field(default=None, repr=False)
    validation: ValidationReport | None = field(default=None, repr=False)

    @property
    def covariance(self) -> np.ndarray:
        """The best covariance (customary units): GUF when validated or alone, else MCM."""
        if self.mcm is not None and (
            self.guf is None or (self.validation is not None and not self.validation.passed)
        ):
            return np.asarray(self.mcm.covariance)
        return self.guf.covariance

    def to_dict(self) -> dict:
        """``guf``/``mcm`` blocks with ``outputs`` in the brief's layout, ``validation``."""
        doc: dict = {"input_covariance": self.source}
        if self.guf is not None:
            g = self.guf
            doc["guf"] = {
                "method": "guf",
                "outputs": [o.to_dict() for o in g.outputs],
                "correlation": {"names": list(g.names), "matrix": g.correlation.tolist()},
                "largest_eigenvalue": g.largest_eigenvalue,
                "joint_coverage": joint_coverage(len(g.names), g.p),
                "sensitivity_method": g.sensitivity_method,
            }
        if self.mcm is not None:
            mc = self.mcm
            doc["mcm"] = {
                "method": "mcm",
                "outputs": [o.to_dict() for o in mc.outputs],
                "trials": mc.trials,
                "sequences": mc.sequences,
                "adaptive": mc.converged is not None,
                "converged": mc.converged,
                "correlation": mc.correlation.tolist(),
                # the MC output PDFs (JCGM 101 7.5.1), for plots against the GUF normals
                "histograms": [
                    {"density": h.values.tolist(), "edges": h.edges.tolist()} for h in mc.histograms
                ],
                "largest_eigenvalue": mc.largest_eigenvalue,
                "joint_coverage_factor": mc.region_coverage_factor,
                "joint_rectangular_coverage_factor": mc.rectangular_coverage_factor,
                "message": mc.message,
            }
        if self.validation is not None:
            doc["validation"] = {**self.validation.to_dict(), "table": self.validation_table()}
        return doc

    def validation_table(self) -> list[dict]:
        """Per parameter (Sepahi Boroujeni (2021) Table 5-2 layout) and joint (Table 5-3)."""
        rows = {(r.name, r.quantity): r for r in self.validation.rows}
        table = []
        for j, name in enumerate(self.guf.names):
            y, u = rows[(name, "estimate")], rows[(name, "standard uncertainty")]
            table.append(
                {
                    "name": name,
                    "unit": self.guf.units[j],
                    "value_mcm": y.mcm,
                    "value_guf": y.guf,
                    "u_mcm": u.mcm,
                    "u_guf": u.guf,
                    "tolerance": y.tolerance,
                    "validated": y.passed and u.passed,
                }
            )
        for quantity in ("largest eigenvalue", "coverage factor"):
            r = rows[("all", quantity)]
            table.append(
                {
                    "name": quantity,
                    "unit": "1",
                    "value_mcm": r.mcm,
                    "value_guf": r.guf,
                    "tolerance": r.tolerance,
                    "validated": r.passed,
                }
            )
        return table


def validate(guf: GUFResult, mcm: MCMResult, digits: int = 2) -> ValidationReport:
    """JCGM 102 §8 validation of the GUF by the MCM, per parameter and jointly.

    δ follows from ``digits`` significant digits of each GUF standard uncertainty
    (JCGM 101:2008, 7.9.2); ρ and κ_p from two digits of the MCM λ_max and k_p.
    """
    delta = numerical_tolerance(guf.standard_uncertainty, digits)
    return validate_guf(
        guf.estimate,
        guf.covariance,
        mcm,
        tolerance=Tolerance(delta),
        p=guf.p,
        guf_coverage_factor=guf.region_coverage_factor,
        names=guf.names,
    )


def evaluate_uncertainty(
    calibration: SambaCalibration,
    inputs: InputSet,
    source: str,
    *,
    method: str = "both",
    trials: int | None = None,
    adaptive: bool = False,
    digits: int = 2,
    seed: SeedLike = None,
    executor=None,
    p: float = 0.95,
) -> SambaUncertainty:
    """GUF, MCM or both (``method``), and the validation when both ran."""
    if method not in ("guf", "mcm", "both"):
        raise InputError(f"uncertainty method must be none, guf, mcm or both, got {method!r}")
    g = identification_guf(calibration, inputs, p) if method in ("guf", "both") else None
    mc = None
    if method in ("mcm", "both"):
        mc = identification_mcm(
            calibration,
            inputs,
            trials=trials,
            adaptive=adaptive,
            digits=digits,
            seed=seed,
            executor=executor,
            p=p,
        )
    v = validate(g, mc, digits) if g is not None and mc is not None else None
    return SambaUncertainty(source, g, mc, v)
