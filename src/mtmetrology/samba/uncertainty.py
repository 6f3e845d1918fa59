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

GUF, Monte Carlo and validation
-------------------------------
Through the identification engine (:mod:`mtmetrology.identification.uncertainty`): the
GUF of the machine errors through the full Jacobian with the nuisance unknowns (ball
centres, tool) marginalised, the Monte Carlo that re-solves the identification in every
trial, and the JCGM 102 §8 validation of the one by the other; the joint coverage factors
(``sqrt(χ²_m(p))`` against the thesis's Bonferroni ``k_q``) are reported with the GUF.

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

from mtmetrology.errors import InputError
from mtmetrology.identification import BallCentreProblem
from mtmetrology.identification.uncertainty import (
    IdentificationModel,
    identification_guf,
    identification_mcm,
    joint_coverage,
    validate_identification,
)
from mtmetrology.rng import SeedLike
from mtmetrology.samba.calibrate import SambaCalibration
from mtmetrology.samba.notebook import SambaNotebookRepr
from mtmetrology.uncertainty import GUFResult, InputQuantity, InputSet, MCMResult, Normal
from mtmetrology.uncertainty.coverage import DEFAULT_P
from mtmetrology.uncertainty.validation import ValidationReport

__all__ = [
    "SambaUncertainty",
    "evaluate_uncertainty",
    "indication_inputs",
    "pooled_sigma",
    "uncertainty_model",
]


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

    def __repr__(self) -> str:
        """The methods run, the validation, and each parameter's value and u (customary
        units, GUM 7.2.6 digits) from the covariance :attr:`covariance` takes."""
        from mtmetrology.formatting import format_parameters

        use_mcm = self.mcm is not None and (
            self.guf is None or (self.validation is not None and not self.validation.passed)
        )
        run = self.mcm if use_mcm else self.guf
        methods = [m for m, r in (("GUF", self.guf), ("Monte Carlo", self.mcm)) if r is not None]
        if self.mcm is not None:
            methods[-1] += f" ({self.mcm.trials} trials)"
        checked = "" if self.validation is None else f"; GUF validated: {self.validation.passed}"
        o = run.outputs
        lines = format_parameters(
            [x.name for x in o], [x.value for x in o], [x.u for x in o], [x.unit for x in o]
        )
        return (
            f"SambaUncertainty(input covariance from {self.source}; {', '.join(methods)}"
            f"{checked}; u from the {'Monte Carlo' if use_mcm else 'GUF'}:\n  "
            + "\n  ".join(lines)
            + ")"
        )

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


def uncertainty_model(calibration: SambaCalibration) -> IdentificationModel:
    """The identification of ``calibration`` as a measurement model of the machine errors
    (customary units), for :func:`~mtmetrology.identification.uncertainty.identification_guf`
    and :func:`~mtmetrology.identification.uncertainty.identification_mcm`."""
    return IdentificationModel(
        calibration.problem, calibration.identification, machine=calibration.machine
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
    p: float = DEFAULT_P,
    progress=None,
) -> SambaUncertainty:
    """GUF, MCM or both (``method``), and the validation when both ran.

    ``progress(done, total)`` is called as the Monte Carlo trials are evaluated (total None
    in an adaptive run), for a progress display.

    When the calibration's covariance was scaled by the adequacy rule (s², the residuals
    contradicting the stated noise), every input covariance is scaled by s² too: the
    measurement model is that of the identification with the inputs' u times s.
    """
    if method not in ("guf", "mcm", "both"):
        raise InputError(f"uncertainty method must be none, guf, mcm or both, got {method!r}")
    factor = calibration.covariance_factor
    if factor != 1.0:
        # the adequacy rule scaled the covariance by s²: propagate the inputs that covariance
        # stands for, every u times s (Birge), so that GUF, MCM and validation agree with it
        inputs = InputSet.from_covariance(
            inputs.names, inputs.estimate, inputs.covariance * factor, units=inputs.units
        )
    model = uncertainty_model(calibration)
    g = identification_guf(model, inputs, p) if method in ("guf", "both") else None
    mc = None
    if method in ("mcm", "both"):
        mc = identification_mcm(
            model,
            inputs,
            trials=trials,
            adaptive=adaptive,
            digits=digits,
            seed=seed,
            executor=executor,
            p=p,
            progress=progress,
        )
    v = validate_identification(g, mc, digits) if g is not None and mc is not None else None
    return SambaUncertainty(source, g, mc, v)
