"""Tests for mtmetrology.history.drift: drift recovery and the due date."""

from __future__ import annotations

from datetime import datetime, timedelta

import numpy as np
import pytest
from scipy import stats

from mtmetrology.errors import InputError
from mtmetrology.history import DriftResult, fit_drift

START = datetime(2026, 1, 5, 7, 0)


def _series(rng, slope, q, u, k, every=7.0):
    days = np.arange(k) * every
    steps = slope * every + rng.normal(0.0, np.sqrt(q * every), k - 1)
    truth = 2.0 + np.r_[0.0, np.cumsum(steps)]
    dates = [START + timedelta(days=float(d)) for d in days]
    return dates, truth + rng.normal(0.0, u, k)


def test_sign_convention_and_due_date_of_a_noise_free_linear_drift():
    """x = 2 + 0.1 µm/day, u = 1 nm, no random walk: slope +0.1 (positive: the parameter
    grows), and with MPE 10 µm the due date is the first day the prediction crosses it."""
    days = np.arange(10) * 7.0
    dates = [START + timedelta(days=float(d)) for d in days]
    fit = fit_drift("E_X0C", "µm", dates, 2 + 0.1 * days, np.full(10, 1e-3), mpe=10.0)
    assert fit.slope == pytest.approx(0.1, rel=1e-6)
    assert fit.level == pytest.approx(2 + 0.1 * 63, rel=1e-6)
    assert fit.random_walk_variance < 1e-9
    # 8.3 + 0.1 d reaches 10 at d = 17 (the 5 % tail of a nm-wide prediction: same day)
    assert fit.due_date == dates[-1] + timedelta(days=17)
    assert DriftResult.from_dict(fit.to_dict()).to_dict() == fit.to_dict()


def test_simulated_drift_is_recovered_within_its_uncertainty():
    """200 series of 120 weekly calibrations, slope 0.05 µm/day, random walk q = 0.05
    µm²/day, u = 0.5 µm. The slope lies within ±2 u(slope) for a fraction in the 99.9 %
    binomial acceptance region of p = 0.9545 (the u is conditional on q̂: 1 series in
    200 at ±2u would be the plug-in's toll at K = 120); the median of q̂/q is within
    [0.85, 1.15] (the ML estimate of one series spreads about ±30 %: ~2 % for the median
    of 200)."""
    rng = np.random.default_rng(2024)
    slope, q, u, k, n = 0.05, 0.05, 0.5, 120, 200
    inside, ratios = 0, []
    for _ in range(n):
        dates, y = _series(rng, slope, q, u, k)
        fit = fit_drift("E_X0C", "µm", dates, y, np.full(k, u))
        inside += abs(fit.slope - slope) <= 2 * fit.u_slope
        ratios.append(fit.random_walk_variance / q)
    low, high = stats.binom.ppf([0.0005, 0.9995], n, 0.9545)
    assert low <= inside <= high
    assert 0.85 <= np.median(ratios) <= 1.15


def test_exceedance_at_the_due_date_checked_by_simulation():
    """The due date's predicted P(|x| > MPE) (closed form) passes 1 − R there and not the
    day before; simulating the model (state drawn from the filter's posterior, then the
    slope and the random walk to the due date) gives the same probability within the
    99.9 % binomial region of 10^5 draws."""
    rng = np.random.default_rng(7)
    dates, y = _series(rng, 0.02, 0.01, 0.3, 40)
    fit = fit_drift("E_X0C", "µm", dates, y, np.full(40, 0.3), mpe=6.0, reliability=0.9)
    assert fit.due_date is not None and fit.due_date > fit.last_date
    before, at = fit.exceedance_probability([fit.due_date - timedelta(days=1), fit.due_date])
    assert before <= 0.1 < at
    d = (fit.due_date - fit.last_date).days
    draws = 100_000
    state = rng.multivariate_normal([fit.level, fit.slope], fit.covariance, size=draws)
    x = state[:, 0] + state[:, 1] * d + rng.normal(0, np.sqrt(fit.random_walk_variance * d), draws)
    exceed = np.count_nonzero(np.abs(x) > fit.mpe)
    low, high = stats.binom.ppf([0.0005, 0.9995], draws, at)
    assert low <= exceed <= high


def test_missing_uncertainty_and_too_few_runs_are_refused():
    dates = [START + timedelta(days=i) for i in range(5)]
    with pytest.raises(InputError, match="E_X0C: every calibration needs its standard"):
        fit_drift("E_X0C", "µm", dates, np.zeros(5), np.full(5, np.nan))
    with pytest.raises(InputError, match="at least 4 calibrations, got 3"):
        fit_drift("E_X0C", "µm", dates[:3], np.zeros(3), np.ones(3))
