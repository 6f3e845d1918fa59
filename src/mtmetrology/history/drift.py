"""Drift of an error parameter between calibrations, and the date its next calibration is due.

Measurement model (a local linear trend, Harvey (1989), §2.3.2, with a constant slope): the
machine's true parameter x(t) drifts with a constant slope β plus a random walk of
diffusion variance q (unit² per day); calibration k, at t_k, measures it with the
calibration's own standard uncertainty u_k, independently::

    x(t_k) = x(t_{k-1}) + β (t_k − t_{k-1}) + w_k,   w_k ~ N(0, q (t_k − t_{k-1}))
    y_k    = x(t_k) + ε_k,                           ε_k ~ N(0, u_k²)

The Kalman filter on the state (x, β) with a diffuse start gives the level and slope after
the last calibration with their covariance; q is the maximum-likelihood value of the
prediction-error decomposition (the first two innovations, spent on the diffuse start,
excluded). The prediction of x at t > t_K has variance
P_xx + 2 Δ P_xβ + Δ² P_ββ + q Δ (Δ = t − t_K).

The due date is the first day on which the predicted probability that |x| exceeds the
maximum permissible error (MPE) passes 1 − R, R the reliability target: the interval
method of ILAC-G24:2022 / OIML D 10 ("method 1" adjusted to a reliability target) and
NCSLI RP-1 (reliability target, e.g. R = 0.95 in-tolerance at the end of the interval).

References
----------
Harvey, A. C. (1989). *Forecasting, Structural Time Series Models and the Kalman Filter*.
Cambridge University Press, §2.3.2 and §3.4 (prediction-error decomposition).

ILAC-G24:2022 / OIML D 10:2022. *Guidelines for the determination of recalibration
intervals of measuring equipment*.

NCSL International (2010). *RP-1: Establishment and Adjustment of Calibration Intervals*.
"""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime, timedelta

import numpy as np
from scipy.optimize import minimize_scalar
from scipy.special import ndtr

from mtmetrology.errors import InputError

__all__ = ["DriftResult", "fit_drift", "kalman_filter"]

_DAY = 86400.0


def kalman_filter(t: np.ndarray, y: np.ndarray, u: np.ndarray, q: float):
    """Kalman filter of the local linear trend with a constant slope.

    Parameters
    ----------
    t : (K,) array, days, increasing
    y, u : (K,) arrays, measured values and their standard uncertainties (one unit)
    q : float
        Random-walk diffusion variance, unit² per day.

    Returns
    -------
    state : (2,) array
        Level and slope (unit, unit/day) after the last measurement.
    covariance : (2, 2) array
    loglik : float
        Log-likelihood of the innovations after the first two (which start the filter
        exactly: the limit of a diffuse prior).
    """
    # exact start from the first two measurements (what a diffuse prior tends to, without
    # its cancellation): level y₁ (error ε₁), slope (y₁ − y₀)/Δ (error (w + ε₁ − ε₀)/Δ)
    d1 = float(t[1] - t[0])
    r0, r1 = float(u[0]) ** 2, float(u[1]) ** 2
    a, b = float(y[1]), float(y[1] - y[0]) / d1
    paa, pab, pbb = r1, r1 / d1, (r0 + r1 + q * d1) / d1**2
    loglik = 0.0
    for k in range(2, len(t)):
        dt = float(t[k] - t[k - 1])
        a += b * dt  # predict: x ← x + β Δt, P ← F P Fᵀ + diag(q Δt, 0)
        paa, pab = paa + 2 * dt * pab + dt * dt * pbb + q * dt, pab + dt * pbb
        innovation = float(y[k]) - a
        r = float(u[k]) ** 2
        s = paa + r
        a, b = a + paa / s * innovation, b + pab / s * innovation  # gain (paa, pab) / s
        # P ← (I − K H) P, written so that a diffuse paa does not cancel: paa r / s ...
        paa, pab, pbb = paa * r / s, pab * r / s, pbb - pab * pab / s
        loglik -= 0.5 * (np.log(2 * np.pi * s) + innovation**2 / s)
    return np.array([a, b]), np.array([[paa, pab], [pab, pbb]]), loglik


@dataclass(frozen=True)
class DriftResult:
    """Fitted drift of one parameter and its due date (customary unit, days).

    Attributes
    ----------
    parameter, unit : str
    last_date : datetime
        The last calibration (the prediction's origin).
    level : float
        Filtered value of x at ``last_date``.
    slope : float
        β, unit per day; positive: the parameter grows with time.
    covariance : (2, 2) ndarray
        Of (level, slope).
    random_walk_variance : float
        q, unit² per day.
    mpe : float or None
        Maximum permissible error |x| ≤ MPE.
    reliability : float
        Target probability of being in tolerance at the due date.
    due_date : datetime or None
        First day with P(|x| > MPE) > 1 − reliability (None without an MPE, or beyond
        ``horizon_days``); ``last_date`` itself when already beyond.
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

    @property
    def u_slope(self) -> float:
        """Standard uncertainty of the slope, unit per day."""
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
        """JSON form (``kind: history-drift``, version 1)."""
        return {
            "kind": "history-drift",
            "version": 1,
            "parameter": self.parameter,
            "unit": self.unit,
            "model": "local linear trend, constant slope + random walk (Kalman filter, ML q)",
            "last_date": self.last_date.isoformat(),
            "level": self.level,
            "slope_per_day": self.slope,
            "covariance": self.covariance.tolist(),
            "random_walk_variance_per_day": self.random_walk_variance,
            "mpe": self.mpe,
            "reliability": self.reliability,
            "due_date": None if self.due_date is None else self.due_date.isoformat(),
        }

    @classmethod
    def from_dict(cls, doc: dict) -> DriftResult:
        """Inverse of :meth:`to_dict`."""
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
        )


def _prediction(fit, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    p = fit.covariance
    mean = fit.level + fit.slope * d
    var = p[0, 0] + 2 * d * p[0, 1] + d**2 * p[1, 1] + fit.random_walk_variance * d
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
) -> DriftResult:
    """Fit the drift model to one parameter's calibrations and find the due date.

    Parameters
    ----------
    parameter, unit : str
    dates : sequence of datetime, increasing
    values, u : (K,) arrays
        Calibrated values and their standard uncertainties (the unit), K >= 4.
    mpe : float, optional
        Maximum permissible error of |x|, the unit.
    reliability : float
        In-tolerance probability required at the due date (0.5 < R < 1).
    horizon_days : int
        How far ahead the due date is searched (days).

    Returns
    -------
    DriftResult
    """
    y = np.asarray(values, dtype=float)
    u = np.asarray(u, dtype=float)
    if len(y) < 4:
        raise InputError(f"{parameter}: a drift model needs at least 4 calibrations, got {len(y)}")
    if np.any(~np.isfinite(u)) or np.any(u <= 0):
        raise InputError(
            f"{parameter}: every calibration needs its standard uncertainty u > 0 for the drift "
            "model (record calibrations with a covariance)"
        )
    if not 0.5 < reliability < 1:
        raise InputError(f"reliability {reliability}: must be between 0.5 and 1")
    t = np.array([(d - dates[0]).total_seconds() / _DAY for d in dates])
    if np.any(np.diff(t) <= 0):
        raise InputError(f"{parameter}: two calibrations at the same time; dates must increase")
    span = max(float(t[-1]), 1.0)
    scale2 = max(float(np.var(np.diff(y))), float(np.mean(u**2)), 1e-30) / span * len(y)

    def negative(log_q):
        return -kalman_filter(t, y, u, scale2 * np.exp(log_q))[2]

    best = minimize_scalar(negative, bounds=(-25.0, 5.0), method="bounded")
    q = float(scale2 * np.exp(best.x))
    if best.x < -24.0:
        q = 0.0  # no random walk detectable: the boundary of the parameter space
    state, cov, _ = kalman_filter(t, y, u, q)
    fit = DriftResult(
        parameter,
        unit,
        dates[-1],
        float(state[0]),
        float(state[1]),
        cov,
        q,
        mpe,
        reliability,
        None,
    )
    if mpe is None:
        return fit
    days = np.arange(0, horizon_days + 1, dtype=float)
    mean, std = _prediction(fit, days)
    beyond = np.nonzero(_exceedance(mean, std, mpe) > 1 - reliability)[0]
    due = None if beyond.size == 0 else dates[-1] + timedelta(days=int(days[beyond[0]]))
    return DriftResult(
        parameter, unit, dates[-1], fit.level, fit.slope, cov, q, mpe, reliability, due
    )
