"""cov(e) from repeated SAMBA campaigns: the scatter of the residual field between campaigns.

K campaigns repeat the same SAMBA test (same balls, indexations and styli, in the same
order; one records file each, on different days or set-ups). Each is calibrated on its
own (:func:`mtmetrology.samba.calibrate`), giving the residual field r_{k,s} (compensated
position minus identified ball centre, mm) at the n common positions s. The
unexplained volumetric error of a future campaign is what changes from one campaign to
the next beyond the probing noise, so its covariance is estimated from the scatter of the
residual field between campaigns at the common positions (method of moments, the
estimator of :mod:`mtmetrology.uncertainty.unexplained_estimate`):

    d_{k,s} = r_{k,s} − r̄_s,        r̄_s = (1/K) Σ_k r_{k,s},
    Ĉ_between = Σ_k Σ_s d_{k,s} d_{k,s}ᵀ / ν − σ² I,     ν = (K − 1)(n − p/3),

with p the unknowns of each campaign's fit (machine parameters, ball centres, tools) and
σ² I the indication noise the calibrations were weighted with (the repeatability part,
which the task model already holds), made positive semidefinite by eigenvalue clipping.
ν follows from r_k = (I − H)(e_k + v_k) for the common hat matrix H of the identical
tests: the centring over campaigns removes n positions' worth (3n) and each fit p/3 per
coordinate, (K − 1) times.

Beside it the result gives the pooled within-campaign estimate (the one of ``mtm samba
calibrate --unexplained-out``, ν = K(n − p/3)), which also holds the part of e that repeats
identically at every position in every campaign (a stable unmodelled error field) — the
between-campaign estimate does not: the difference says whether the unexplained error is
a stable field (a richer model would remove it) or changes between campaigns.

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, §6.3.3, eqs. 6-13 to 6-15.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mtmetrology.display import NotebookRepr
from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.samba.artefact import SambaArtefact
from mtmetrology.samba.calibrate import calibrate
from mtmetrology.samba.records import SambaRecords
from mtmetrology.uncertainty.unexplained_estimate import (
    UnexplainedCovariance,
    estimate_unexplained_covariance,
)
from mtmetrology.units import from_internal, to_internal

__all__ = ["CampaignUnexplained", "unexplained_from_campaigns"]

ESTIMATOR = (
    "between campaigns: Σ_k Σ_s (r_ks − r̄_s)(r_ks − r̄_s)ᵀ / ν − σ² I, ν = (K − 1)(n − p/3); "
    "eigenvalues clipped at 0 (nearest PSD, Higham 1988)"
)


@dataclass(frozen=True, eq=False)
class CampaignUnexplained(NotebookRepr):
    """Result of :func:`unexplained_from_campaigns`.

    Attributes
    ----------
    between : UnexplainedCovariance
        Ĉ_between (module notes): the cov(e) written to E.json.
    within : UnexplainedCovariance
        The pooled within-campaign estimate (ν = K(n − p/3)), for comparison.
    campaigns : tuple of str
        The records files, in order.
    residuals : (K, n, 3) ndarray, mm
        Residual field of each campaign.
    fitted_parameters : int
        p, unknowns of each campaign's fit.
    sigma : float
        Indication noise σ (mm) the calibrations were weighted with.
    """

    between: UnexplainedCovariance
    within: UnexplainedCovariance
    campaigns: tuple[str, ...]
    residuals: np.ndarray = field(repr=False)
    fitted_parameters: int
    sigma: float

    _renderer_module = "mtmetrology.samba.report"

    def to_dict(self) -> dict:
        """The ``unexplained-volumetric-error`` document of ``mtm samba calibrate
        --unexplained-out`` (covariance µm², what ``mtm task uncertainty --unexplained``
        reads), with the campaigns, the estimator and the within-campaign estimate."""
        doc = self.between.to_dict()
        doc["estimate"].update(
            {
                "estimator": ESTIMATOR,
                "campaigns": list(self.campaigns),
                "positions": int(self.residuals.shape[1]),
                "fitted_parameters_per_campaign": self.fitted_parameters,
                "sigma_um": float(from_internal(self.sigma, "µm")),
                "residuals_um": from_internal(self.residuals, "µm").tolist(),
                "within": self.within.to_dict(),
            }
        )
        return doc

    @classmethod
    def from_dict(cls, doc: dict) -> CampaignUnexplained:
        """Inverse of :meth:`to_dict`."""
        est = doc["estimate"]
        return cls(
            between=UnexplainedCovariance.from_dict(doc),
            within=UnexplainedCovariance.from_dict(est["within"]),
            campaigns=tuple(est["campaigns"]),
            residuals=to_internal(np.array(est["residuals_um"], float), "µm"),
            fitted_parameters=int(est["fitted_parameters_per_campaign"]),
            sigma=float(to_internal(est["sigma_um"], "µm")),
        )


def _check_same_test(first: SambaRecords, other: SambaRecords, machine: Machine) -> None:
    """Refuse a campaign whose indications are not those of the first (ball, pose, tool)."""
    pose = [i for i, a in enumerate(machine.axis_names) if a in ("B", "C", "S")]
    if len(other) != len(first):
        raise InputError(
            f"{other.source}: {len(other)} indications where {first.source} has "
            f"{len(first)}; every campaign must repeat the same test"
        )
    tools_a = first.tools or ("",) * len(first)
    tools_b = other.tools or ("",) * len(other)
    moved = np.any(np.abs(first.readings[:, pose] - other.readings[:, pose]) > 1e-9, axis=1)
    differ = [a != b for a, b in zip(first.balls, other.balls, strict=True)]
    differ = np.array(differ) | moved | [a != b for a, b in zip(tools_a, tools_b, strict=True)]
    if differ.any():
        k = int(np.flatnonzero(differ)[0])
        raise InputError(
            f"{other.source}, line {other.lines[k]}: indication {k + 1} (ball "
            f"{other.balls[k]!r}) is not the position of {first.source}, line "
            f"{first.lines[k]} (ball {first.balls[k]!r}): every campaign must probe "
            "the same balls at the same indexations in the same order"
        )


def unexplained_from_campaigns(
    machine: Machine,
    campaigns: list[SambaRecords],
    artefact: SambaArtefact,
    *,
    sigma: float,
    estimate_tool: bool = False,
) -> CampaignUnexplained:
    """Estimate cov(e) from K repeated SAMBA campaigns (module notes give the estimator).

    Parameters
    ----------
    machine : Machine
        With the error model each campaign is calibrated with.
    campaigns : list of SambaRecords, length K ≥ 2
        The records of each campaign (:func:`mtmetrology.samba.read_records`), the same
        test each time.
    artefact : SambaArtefact
    sigma : float
        Standard uncertainty of one indication coordinate, mm: the calibrations' weight
        and the noise σ² I removed from the estimate.
    estimate_tool : bool
        Identify the tool vector(s) in each campaign.

    Returns
    -------
    CampaignUnexplained

    Raises
    ------
    InputError
        Fewer than two campaigns, campaigns that are not the same test (naming the file
        and line), no degrees of freedom left.
    RankDeficientError, ConvergenceError
        From the calibration of a campaign.

    Notes
    -----
    ``Ĉ = Σ_k Σ_s (r_ks − r̄_s)(r_ks − r̄_s)ᵀ / ν − σ² I``, ``ν = (K − 1)(n − p/3)``:
    :func:`~mtmetrology.uncertainty.unexplained_estimate.estimate_unexplained_covariance`
    on the K·n centred residuals with ``3n + (K − 1)p`` fitted parameters.
    """
    k = len(campaigns)
    if k < 2:
        raise InputError(
            f"cov(e) between campaigns needs at least 2 campaign files, got {k}; "
            "for one campaign use mtm samba calibrate --unexplained-out"
        )
    for other in campaigns[1:]:
        _check_same_test(campaigns[0], other, machine)
    cals = [
        calibrate(machine, rec, artefact, sigma=sigma, estimate_tool=estimate_tool)
        for rec in campaigns
    ]
    r = np.stack([c.residual_vectors for c in cals])  # (K, n, 3)
    n = r.shape[1]
    p = len(cals[0].identification.estimate)
    noise = sigma**2 * np.eye(3)
    sources = tuple(rec.source for rec in campaigns)
    label = f"SAMBA residuals of {k} campaigns ({', '.join(sources)}; {n} positions each)"
    between = estimate_unexplained_covariance(
        (r - r.mean(axis=0)).reshape(-1, 3),
        fitted_parameters=3 * n + (k - 1) * p,
        noise_covariance=noise,
        source=label,
    )
    within = estimate_unexplained_covariance(
        r.reshape(-1, 3), fitted_parameters=k * p, noise_covariance=noise, source=label
    )
    return CampaignUnexplained(between, within, sources, r, p, float(sigma))
