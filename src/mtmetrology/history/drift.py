"""Drift of an error parameter between calibrations, and the date its next calibration is due.

Measurement model (a local linear trend, Harvey (1989), §2.3.2, with a constant slope): the
machine's true parameter x(t) drifts with a constant slope β plus a random walk of
diffusion variance q (unit² per day); calibration k, at t_k, measures it with the
calibration's own standard uncertainty u_k, independently::

    x(t_k) = x(t_{k-1}) + β (t_k − t_{k-1}) + w_k,   w_k ~ N(0, q (t_k − t_{k-1}))
    y_k    = x(t_k) + ε_k,                           ε_k ~ N(0, u_k²)

The Kalman filter on the state (x, β) with a diffuse start gives, for a given q, the level
and slope after the last calibration with their covariance P and the likelihood of q from
the prediction-error decomposition (the first two innovations, spent on the diffuse start,
excluded). The prediction of x at t > t_K has variance
P̄_xx + 2 Δ P̄_xβ + Δ² P̄_ββ + E[q] Δ (Δ = t − t_K), P̄ and E[q] as below.

The due date is the first day on which the predicted probability that |x| exceeds the
maximum permissible error (MPE) passes 1 − R, R the reliability target: the interval
method of ILAC-G24:2022 / OIML D 10 ("method 1" adjusted to a reliability target) and
NCSLI RP-1 (reliability target, e.g. R = 0.95 in-tolerance at the end of the interval).

The random-walk variance q is not known and, from few calibrations, poorly determined: its
maximum-likelihood value is often zero when a real random walk as large as u per interval
is present, and a slope uncertainty conditional on that value is too small (a 2u interval
covering about 81 % of simulated series at 8 runs).  So q is marginalised (Bayesian model
averaging over q; flat prior on level and slope, which makes the filter's likelihood the
restricted likelihood L(q)): with a prior π(q) on a grid of q,

    w_j ∝ L(q_j) π_j,   m̄ = Σ w_j m_j,   E[q] = Σ w_j q_j,
    P̄ = Σ w_j (P_j + (m_j − m̄)(m_j − m̄)ᵀ)   (m = (level, slope), P its covariance given q),

the slope's coverage interval is the probabilistically symmetric interval of the mixture
Σ w_j N(β_j, P_ββ,j) for the stated probability p (JCGM 101:2008, 5.3.3), and the
prediction uses the mixture's mean and covariance and E[q] (its first two moments exactly;
the exceedance probability is that of the Gaussian with those moments).  Priors:

``reference`` (default)
    Jeffreys' rule on the restricted likelihood, π(q) ∝ √(½ tr((P_R C)²)) with
    P_R = V⁻¹ − V⁻¹X(XᵀV⁻¹X)⁻¹XᵀV⁻¹, V = diag(u²) + q C, C_ij = min(t_i, t_j),
    X = [1, t] — the reference prior of one covariance parameter of Berger, De Oliveira &
    Sansó (2001), §3.  No scale is assumed; ∝ 1/q for a large random walk (where the
    slope interval becomes Student's t of the differences).  In simulation (p = 0.9545,
    1000–2000 series each) it does not under-cover — 94–96 % for q Δt = u² at 16–64 runs
    and for q Δt = 10 u² at 8–32 — but is conservative when the walk is small and the
    runs few (99.7 % at 8 runs for q Δt = u²): 8 runs cannot exclude a walk of that size.
    Needs at least 5 calibrations (with 4 the slope's posterior variance is unbounded).
``half-cauchy``
    A half-Cauchy prior on √q with scale A = RMS(u)/√(mean interval): a random walk as
    large as the calibration uncertainty per interval is the prior median (Gelman 2006;
    Polson & Scott 2012).  Calibrated there (94.7 % at 8 runs, 93.6 % at 32 for
    q Δt = u²), but a stated, informative scale: for q Δt = 10 u² it covers 88–90 % at
    5–8 runs.

The reported ``random_walk_variance`` is the restricted-likelihood estimate q̂ (Harvey
1989, §3.4); ``random_walk_variance_mean`` is E[q | data], the one the prediction uses.

References
----------
Harvey, A. C. (1989). *Forecasting, Structural Time Series Models and the Kalman Filter*.
Cambridge University Press, §2.3.2 and §3.4 (prediction-error decomposition).

ILAC-G24:2022 / OIML D 10:2022. *Guidelines for the determination of recalibration
intervals of measuring equipment*.

NCSL International (2010). *RP-1: Establishment and Adjustment of Calibration Intervals*.

Berger, J. O., De Oliveira, V. & Sansó, B. (2001). Objective Bayesian analysis of spatially
correlated data. *J. Amer. Statist. Assoc.* 96(456), 1361–1374.

Gelman, A. (2006). Prior distributions for variance parameters in hierarchical models.
*Bayesian Analysis* 1(3), 515–534.  Polson, N. G. & Scott, J. G. (2012). On the
half-Cauchy prior for a global scale parameter. *Bayesian Analysis* 7(4), 887–902.

JCGM 101:2008, *Propagation of distributions using a Monte Carlo method*, 5.3.3.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from datetime import datetime, timedelta

import numpy as np
from scipy.optimize import brentq, minimize_scalar
from scipy.special import ndtr

from mtmetrology.errors import InputError
from mtmetrology.uncertainty.coverage import DEFAULT_P

__all__ = ["PRIORS", "DriftResult", "fit_drift", "kalman_filter"]

_DAY = 86400.0
#: Priors of the random-walk variance q (module notes).
PRIORS = ("reference", "half-cauchy")
#: Above this many calibrations the reference prior (an eigendecomposition of the K × K
#: random-walk covariance: O(K³) time, 8K² bytes) gives way to the half-Cauchy prior, which
#: the result then names: with so many runs the likelihood decides the posterior of q.
REFERENCE_PRIOR_MAX_RUNS = 1000
#: Grid of √q: nodes per decade and decades below the prior's scale (the node q = 0 holds
#: the mass beneath); enough for the narrow posterior of a long series (±30 % at 120 runs).
_PER_DECADE, _BELOW = 40, 6


def kalman_filter(t: np.ndarray, y: np.ndarray, u: np.ndarray, q):
    """Kalman filter of the local linear trend with a constant slope.

    Parameters
    ----------
    t : (K,) array, days, increasing
    y, u : (K,) arrays, measured values and their standard uncertainties (one unit)
    q : float or array
        Random-walk diffusion variance, unit² per day; an array filters every value at once.

    Returns
    -------
    state : (..., 2) array
        Level and slope (unit, unit/day) after the last measurement.
    covariance : (..., 2, 2) array
    loglik : float or array
        Log-likelihood of the innovations after the first two (which start the filter
        exactly: the limit of a diffuse prior), i.e. the restricted likelihood of q.
    """
    q = np.asarray(q, dtype=float)
    # exact start from the first two measurements (what a diffuse prior tends to, without
    # its cancellation): level y₁ (error ε₁), slope (y₁ − y₀)/Δ (error (w + ε₁ − ε₀)/Δ)
    d1 = float(t[1] - t[0])
    r0, r1 = float(u[0]) ** 2, float(u[1]) ** 2
    a = np.full(q.shape, float(y[1]))
    b = np.full(q.shape, float(y[1] - y[0]) / d1)
    paa, pab, pbb = np.full(q.shape, r1), np.full(q.shape, r1 / d1), (r0 + r1 + q * d1) / d1**2
    loglik = np.zeros(q.shape)
    for k in range(2, len(t)):
        dt = float(t[k] - t[k - 1])
        a = a + b * dt  # predict: x ← x + β Δt, P ← F P Fᵀ + diag(q Δt, 0)
        paa, pab = paa + 2 * dt * pab + dt * dt * pbb + q * dt, pab + dt * pbb
        innovation = float(y[k]) - a
        r = float(u[k]) ** 2
        s = paa + r
        a, b = a + paa / s * innovation, b + pab / s * innovation  # gain (paa, pab) / s
        # P ← (I − K H) P, written so that a diffuse paa does not cancel: paa r / s ...
        paa, pab, pbb = paa * r / s, pab * r / s, pbb - pab * pab / s
        loglik = loglik - 0.5 * (np.log(2 * np.pi * s) + innovation**2 / s)
    cov = np.stack([np.stack([paa, pab], -1), np.stack([pab, pbb], -1)], -2)
    return np.stack([a, b], -1), cov, loglik if q.ndim else float(loglik)


def _reference_prior(t: np.ndarray, u: np.ndarray, q: np.ndarray) -> np.ndarray:
    """π(q) ∝ √(½ tr((P_R C)²)) (module notes), for every q at once.

    In the frame whitened by the calibrations' u and rotated to the eigenvectors of
    C̃ = diag(1/u) C diag(1/u) = Q Λ Qᵀ, V⁻¹ is diagonal, d = 1/(1 + q λ), and with
    Z = Qᵀ diag(1/u) X, M = Zᵀ D Z:  tr((P C)²) = Σ d²λ² − 2 Σ d³λ² g + tr((M⁻¹H)²),
    g = diag(Z M⁻¹ Zᵀ), H = Zᵀ diag(d²λ) Z.
    """
    tt = t - t[0]
    w = 1.0 / u
    lam, vec = np.linalg.eigh(np.minimum.outer(tt, tt) * np.outer(w, w))
    lam = np.clip(lam, 0.0, None)
    z = vec.T @ (np.column_stack([np.ones_like(tt), tt]) * w[:, None])
    d = 1.0 / (1.0 + q[:, None] * lam)
    m_inv = np.linalg.inv(np.einsum("ki,qk,kj->qij", z, d, z))
    g = np.einsum("ki,qij,kj->qk", z, m_inv, z)
    mh = m_inv @ np.einsum("ki,qk,kj->qij", z, d * d * lam, z)
    trace = np.sum((d * lam) ** 2 - 2 * d**3 * lam**2 * g, axis=1)
    trace += np.einsum("qij,qji->q", mh, mh)
    return np.sqrt(np.clip(0.5 * trace, 0.0, None))


def _posterior(t, y, u, prior: str):
    """Grid of q, posterior weights and the prior's scale A (unit per √day).

    The nodes are √q = A·10^(j/40) from 10⁻⁶ A up to where the data's own differences
    would all be random walk (×30), and q = 0.  Weights: restricted likelihood × the
    prior's mass of each node's cell (half-Cauchy: exact cell probabilities of √q;
    reference: density × cell width in q; the cell of q = 0 is [0, first node)).
    """
    dt = np.diff(t)
    scale = float(np.sqrt(np.mean(u**2) / np.mean(dt)))
    top = max(1e3 * scale, 30.0 * float(np.sqrt(np.var(np.diff(y)) / dt.min())))
    n = int(np.ceil(_PER_DECADE * (np.log10(top / scale) + _BELOW)))
    root = np.r_[0.0, scale * np.logspace(-_BELOW, np.log10(top / scale), n)]
    edges = np.r_[0.0, root[1], np.sqrt(root[1:-1] * root[2:]), np.inf]
    q = root**2
    state, cov, loglik = kalman_filter(t, y, u, q)
    with np.errstate(divide="ignore"):
        if prior == "half-cauchy":
            mass = np.diff(np.arctan(edges / scale)) * (2 / np.pi)
        else:
            width = np.diff(np.minimum(edges, root[-1] * 10 ** (0.5 / _PER_DECADE)) ** 2)
            mass = _reference_prior(t, u, q) * width
        logw = loglik + np.log(mass)
    w = np.exp(logw - logw.max())
    return q, w / w.sum(), state, cov, scale


def _mixture_interval(mean, sd, w, p: float) -> tuple[float, float]:
    """Probabilistically symmetric p interval of Σ w_j N(mean_j, sd_j²) (JCGM 101, 5.3.3)."""
    keep = w > 1e-14
    mean, sd, w = mean[keep], sd[keep], w[keep] / w[keep].sum()
    lo, hi = float(np.min(mean - 12 * sd)), float(np.max(mean + 12 * sd))

    def quantile(level):
        def f(x):
            return float(w @ ndtr((x - mean) / sd)) - level

        return brentq(f, lo, hi, xtol=1e-12 * (hi - lo))

    return quantile((1 - p) / 2), quantile((1 + p) / 2)


@dataclass(frozen=True)
class DriftResult:
    """Fitted drift of one parameter and its due date (customary unit, days).

    Attributes
    ----------
    parameter, unit : str
    last_date : datetime
        The last calibration (the prediction's origin).
    level : float
        Posterior mean of x at ``last_date`` (q marginalised).
    slope : float
        Posterior mean of β, unit per day; positive: the parameter grows with time.
    covariance : (2, 2) ndarray
        Of (level, slope), q marginalised (module notes).
    random_walk_variance : float
        q̂, the restricted-likelihood estimate, unit² per day.
    mpe : float or None
        Maximum permissible error |x| ≤ MPE.
    reliability : float
        Target probability of being in tolerance at the due date.
    due_date : datetime or None
        First day with P(|x| > MPE) > 1 − reliability (None without an MPE, or beyond
        ``horizon_days``); ``last_date`` itself when already beyond.
    random_walk_variance_mean : float
        E[q | data], unit² per day: the random walk of the prediction.
    slope_interval : (float, float)
        Probabilistically symmetric interval of β for ``coverage_probability``.
    coverage_probability : float
    prior : str
        Prior of q (:data:`PRIORS`).
    prior_scale : float
        A = RMS(u)/√(mean interval), unit per √day (the half-Cauchy prior's scale).
    """

    parameter: str
    unit: str
    last_date: datetime
    level: float
    slope: float
    covariance: np.ndarray
    random_walk_variance: float
    mpe: float | None
    reliability: float
    due_date: datetime | None
    random_walk_variance_mean: float
    slope_interval: tuple[float, float]
    coverage_probability: float
    prior: str
    prior_scale: float

    @property
    def u_slope(self) -> float:
        """Standard uncertainty of the slope (posterior standard deviation), unit per day."""
        return float(np.sqrt(self.covariance[1, 1]))

    def predict(self, dates) -> tuple[np.ndarray, np.ndarray]:
        """Mean and standard deviation of x at ``dates`` (after ``last_date``)."""
        d = np.array([(x - self.last_date).total_seconds() / _DAY for x in dates])
        return _prediction(self, d)

    def exceedance_probability(self, dates) -> np.ndarray:
        """P(|x| > MPE) at ``dates``."""
        if self.mpe is None:
            raise InputError("no maximum permissible error stated (--mpe)")
        mean, std = self.predict(dates)
        return _exceedance(mean, std, self.mpe)

    def to_dict(self) -> dict:
        """JSON form (``kind: history-drift``, version 2)."""
        return {
            "kind": "history-drift",
            "version": 2,
            "parameter": self.parameter,
            "unit": self.unit,
            "model": "local linear trend, constant slope + random walk (Kalman filter); "
            f"random-walk variance marginalised under the {self.prior} prior",
            "last_date": self.last_date.isoformat(),
            "level": self.level,
            "slope_per_day": self.slope,
            "covariance": self.covariance.tolist(),
            "random_walk_variance_per_day": self.random_walk_variance,
            "random_walk_variance_mean_per_day": self.random_walk_variance_mean,
            "slope_interval_per_day": list(self.slope_interval),
            "coverage_probability": self.coverage_probability,
            "prior": self.prior,
            "prior_scale_per_sqrt_day": self.prior_scale,
            "mpe": self.mpe,
            "reliability": self.reliability,
            "due_date": None if self.due_date is None else self.due_date.isoformat(),
        }

    @classmethod
    def from_dict(cls, doc: dict) -> DriftResult:
        """Inverse of :meth:`to_dict`."""
        if doc.get("kind") != "history-drift" or doc.get("version") != 2:
            raise InputError("drift: expected kind 'history-drift' version 2")
        return cls(
            doc["parameter"],
            doc["unit"],
            datetime.fromisoformat(doc["last_date"]),
            doc["level"],
            doc["slope_per_day"],
            np.array(doc["covariance"], dtype=float),
            doc["random_walk_variance_per_day"],
            doc["mpe"],
            doc["reliability"],
            None if doc["due_date"] is None else datetime.fromisoformat(doc["due_date"]),
            doc["random_walk_variance_mean_per_day"],
            tuple(doc["slope_interval_per_day"]),
            doc["coverage_probability"],
            doc["prior"],
            doc["prior_scale_per_sqrt_day"],
        )


def _prediction(fit, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    p = fit.covariance
    mean = fit.level + fit.slope * d
    var = p[0, 0] + 2 * d * p[0, 1] + d**2 * p[1, 1] + fit.random_walk_variance_mean * d
    return mean, np.sqrt(var)


def _exceedance(mean, std, mpe):
    return ndtr((-mpe - mean) / std) + ndtr((mean - mpe) / std)


def fit_drift(
    parameter: str,
    unit: str,
    dates,
    values,
    u,
    *,
    mpe: float | None = None,
    reliability: float = 0.95,
    horizon_days: int = 3650,
    prior: str = "reference",
    coverage_probability: float = DEFAULT_P,
) -> DriftResult:
    """Fit the drift model to one parameter's calibrations and find the due date.

    Parameters
    ----------
    parameter, unit : str
    dates : sequence of datetime, increasing
    values, u : (K,) arrays
        Calibrated values and their standard uncertainties (the unit), K >= 4 (>= 5 with
        the reference prior).
    mpe : float, optional
        Maximum permissible error of |x|, the unit.
    reliability : float
        In-tolerance probability required at the due date (0.5 < R < 1).
    horizon_days : int
        How far ahead the due date is searched (days).
    prior : {"reference", "half-cauchy"}
        Prior of the random-walk variance (module notes); "reference" on more than
        :data:`REFERENCE_PRIOR_MAX_RUNS` calibrations is taken as "half-cauchy", and the
        result's ``prior`` says which was used.
    coverage_probability : float
        Probability of the slope's interval (default 2 Φ(2) − 1 = 0.9545, the ``2u``
        of a Gaussian: :mod:`mtmetrology.uncertainty.coverage`).

    Returns
    -------
    DriftResult

    Raises
    ------
    InputError
        Too few calibrations, a missing or non-positive u, dates not increasing, a
        reliability or probability outside (0.5, 1), an unknown prior.
    """
    y = np.asarray(values, dtype=float)
    u = np.asarray(u, dtype=float)
    if len(y) < 4:
        raise InputError(f"{parameter}: a drift model needs at least 4 calibrations, got {len(y)}")
    if prior not in PRIORS:
        raise InputError(f"--rw-prior {prior!r}: use one of {', '.join(PRIORS)}")
    if prior == "reference" and len(y) < 5:
        raise InputError(
            f"{parameter}: with the reference prior the slope's uncertainty is unbounded from "
            f"{len(y)} calibrations (at least 5 are needed), or state --rw-prior half-cauchy"
        )
    if np.any(~np.isfinite(u)) or np.any(u <= 0):
        raise InputError(
            f"{parameter}: every calibration needs its standard uncertainty u > 0 for the drift "
            "model (record calibrations with a covariance)"
        )
    if mpe is not None and not (math.isfinite(mpe) and mpe > 0):
        raise InputError(f"mpe {mpe}: a maximum permissible error is a positive number")
    if not 0.5 < reliability < 1:
        raise InputError(f"reliability {reliability}: must be between 0.5 and 1")
    if not 0.5 < coverage_probability < 1:
        raise InputError(f"coverage probability {coverage_probability}: must be between 0.5 and 1")
    if prior == "reference" and len(y) > REFERENCE_PRIOR_MAX_RUNS:
        prior = "half-cauchy"
    t = np.array([(d - dates[0]).total_seconds() / _DAY for d in dates])
    if np.any(np.diff(t) <= 0):
        raise InputError(f"{parameter}: two calibrations at the same time; dates must increase")
    span = max(float(t[-1]), 1.0)
    scale2 = max(float(np.var(np.diff(y))), float(np.mean(u**2)), 1e-30) / span * len(y)

    def negative(log_q):
        return -kalman_filter(t, y, u, scale2 * np.exp(log_q))[2]

    best = minimize_scalar(negative, bounds=(-25.0, 5.0), method="bounded")
    q_hat = float(scale2 * np.exp(best.x))
    if best.x < -24.0:
        q_hat = 0.0  # no random walk detectable: the boundary of the parameter space
    q, w, states, covs, scale = _posterior(t, y, u, prior)
    mean = w @ states
    dev = states - mean
    cov = np.einsum("j,jab->ab", w, covs + dev[:, :, None] * dev[:, None, :])
    interval = _mixture_interval(states[:, 1], np.sqrt(covs[:, 1, 1]), w, coverage_probability)
    fit = DriftResult(
        parameter,
        unit,
        dates[-1],
        float(mean[0]),
        float(mean[1]),
        cov,
        q_hat,
        mpe,
        reliability,
        None,
        float(w @ q),
        interval,
        coverage_probability,
        prior,
        scale,
    )
    if mpe is None:
        return fit
    days = np.arange(0, horizon_days + 1, dtype=float)
    mu, std = _prediction(fit, days)
    beyond = np.nonzero(_exceedance(mu, std, mpe) > 1 - reliability)[0]
    due = None if beyond.size == 0 else dates[-1] + timedelta(days=int(days[beyond[0]]))
    return dataclasses.replace(fit, due_date=due)
