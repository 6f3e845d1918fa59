"""Tests for mtmetrology.history.drift: drift recovery and the due date."""

from __future__ import annotations

from datetime import datetime, timedelta

import numpy as np
import pytest
from scipy import stats

from mtmetrology.errors import InputError
from mtmetrology.history import DriftResult, fit_drift
from mtmetrology.history.drift import _reference_prior, kalman_filter

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


def test_a_long_history_takes_the_half_cauchy_prior_and_says_so():
    """Above REFERENCE_PRIOR_MAX_RUNS calibrations the O(K³) reference prior gives way to
    the half-Cauchy one, which the result names; the slope is still recovered."""
    from mtmetrology.history.drift import REFERENCE_PRIOR_MAX_RUNS

    rng = np.random.default_rng(8)
    short = _series(rng, 0.01, 0.0, 0.3, REFERENCE_PRIOR_MAX_RUNS, every=1.0)
    assert fit_drift("E_X0C", "µm", *short, np.full(REFERENCE_PRIOR_MAX_RUNS, 0.3)).prior == (
        "reference"
    )
    k = REFERENCE_PRIOR_MAX_RUNS + 1
    dates, y = _series(rng, 0.01, 0.0, 0.3, k, every=1.0)
    fit = fit_drift("E_X0C", "µm", dates, y, np.full(k, 0.3))
    assert fit.prior == "half-cauchy"
    assert abs(fit.slope - 0.01) < 3 * fit.u_slope


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
    slope and the random walk of the prediction, E[q], to the due date) gives the same
    probability within the 99.9 % binomial region of 10^5 draws."""
    rng = np.random.default_rng(7)
    dates, y = _series(rng, 0.02, 0.01, 0.3, 40)
    fit = fit_drift("E_X0C", "µm", dates, y, np.full(40, 0.3), mpe=6.0, reliability=0.9)
    assert fit.due_date is not None and fit.due_date > fit.last_date
    before, at = fit.exceedance_probability([fit.due_date - timedelta(days=1), fit.due_date])
    assert before <= 0.1 < at
    d = (fit.due_date - fit.last_date).days
    draws = 100_000
    state = rng.multivariate_normal([fit.level, fit.slope], fit.covariance, size=draws)
    x = (
        state[:, 0]
        + state[:, 1] * d
        + rng.normal(0, np.sqrt(fit.random_walk_variance_mean * d), draws)
    )
    exceed = np.count_nonzero(np.abs(x) > fit.mpe)
    low, high = stats.binom.ppf([0.0005, 0.9995], draws, at)
    assert low <= exceed <= high


def _coverage(prior, runs, q_per_u2, n=1000, seed=30):
    """Fraction of n simulated weekly series (u = 0.5 µm, slope 0.05 µm/day, random walk
    q Δt = q_per_u2 · u² per interval) whose stated-p slope interval holds the true slope,
    and the fraction within the plug-in ±2 u(slope) at q̂ (the pre-issue-30 interval)."""
    rng = np.random.default_rng(seed)
    u, every, slope = 0.5, 7.0, 0.05
    steps = slope * every + rng.normal(0.0, u * np.sqrt(q_per_u2), (n, runs - 1))
    y = np.c_[np.zeros(n), np.cumsum(steps, axis=1)] + rng.normal(0.0, u, (n, runs))
    dates = [START + timedelta(days=every * k) for k in range(runs)]
    t, uu = np.arange(runs) * every, np.full(runs, u)
    inside = plug_in = 0
    for row in y:
        fit = fit_drift("E_X0C", "µm", dates, row, uu, prior=prior)
        inside += fit.slope_interval[0] <= slope <= fit.slope_interval[1]
        state, cov, _ = kalman_filter(t, row, uu, fit.random_walk_variance)
        plug_in += abs(state[1] - slope) <= 2 * np.sqrt(cov[1, 1])
    return inside / n, plug_in / n


@pytest.mark.slow
@pytest.mark.parametrize("runs", [8, 32])
def test_half_cauchy_slope_interval_covers_95_percent_with_a_random_walk_of_u(runs):
    """Issue 30: a random walk as large as u per interval, 1000 series: the p = 0.9545
    interval with q marginalised (half-Cauchy prior, scale u per interval) covers 93–97 %
    at 8 and at 32 runs; the plug-in ±2u at q̂ covered about 81 % and 91 %."""
    covered, plug_in = _coverage("half-cauchy", runs, 1.0)
    assert 0.93 <= covered <= 0.97, covered
    assert plug_in < 0.925, plug_in


@pytest.mark.slow
@pytest.mark.parametrize(("runs", "q_per_u2", "low", "high"), [
    (32, 1.0, 0.93, 0.97),  # the data determine q: nominal
    (8, 10.0, 0.93, 0.975),  # a large walk, few runs: nominal (the half-Cauchy: ~0.90)
    (8, 1.0, 0.95, 1.0),  # a walk of u with 8 runs cannot be excluded: conservative
])  # fmt: skip
def test_reference_prior_slope_interval_does_not_under_cover(runs, q_per_u2, low, high):
    """The default (reference) prior assumes no scale: nominal where the runs determine q
    or the walk is large, conservative (not too narrow) where 8 runs cannot tell a walk
    of u from none; 1000 series each."""
    covered, _ = _coverage("reference", runs, q_per_u2)
    assert low <= covered <= high, covered


def test_due_date_uses_the_marginalised_uncertainty():
    """8 runs of a linear drift plus a random walk whose q̂ is zero: the marginalised
    prediction is wider than the plug-in at q̂ (which had no random walk), so the due date
    is earlier, and it is where P(|x| > MPE) of the marginalised prediction passes 1 − R."""
    rng = np.random.default_rng(11)
    for _ in range(50):  # the first series of this seed whose q̂ is zero
        dates, y = _series(rng, 0.05, 0.5**2 / 7, 0.5, 8)
        fit = fit_drift("E_X0C", "µm", dates, y, np.full(8, 0.5), mpe=8.0)
        if fit.random_walk_variance == 0.0:
            break
    assert fit.random_walk_variance == 0.0 and fit.random_walk_variance_mean > 0.0
    t = np.array([(d - dates[0]).days for d in dates], dtype=float)
    state, cov, _ = kalman_filter(t, y, np.full(8, 0.5), 0.0)
    assert fit.u_slope > 1.2 * np.sqrt(cov[1, 1])
    days = np.arange(0, 3651, dtype=float)
    mean = state[0] + state[1] * days
    std = np.sqrt(cov[0, 0] + 2 * days * cov[0, 1] + days**2 * cov[1, 1])
    p_plug = stats.norm.sf((8.0 - mean) / std) + stats.norm.cdf((-8.0 - mean) / std)
    plug_due = fit.last_date + timedelta(days=int(np.argmax(p_plug > 0.05)))
    assert fit.due_date < plug_due
    before, at = fit.exceedance_probability([fit.due_date - timedelta(days=1), fit.due_date])
    assert before <= 0.05 < at


def test_reference_prior_equals_the_restricted_fisher_information():
    """π(q) = √(½ tr((P_R C)²)) computed in the eigenbasis equals the direct K x K formula
    (irregular dates, unequal u), and the filter's likelihood differences between two q
    equal those of the restricted likelihood −½(log|V| + log|XᵀV⁻¹X| + yᵀP_R y)."""
    rng = np.random.default_rng(3)
    t = np.r_[0.0, np.cumsum(rng.uniform(3, 20, 9))]
    u = rng.uniform(0.2, 0.8, 10)
    y = 0.05 * t + rng.normal(0, 0.5, 10)
    q = np.array([0.0, 1e-3, 0.03, 1.0])
    c = np.minimum.outer(t, t)
    x = np.column_stack([np.ones(10), t])
    direct, restricted = [], []
    for qq in q:
        v_inv = np.linalg.inv(np.diag(u**2) + qq * c)
        m = x.T @ v_inv @ x
        p = v_inv - v_inv @ x @ np.linalg.solve(m, x.T @ v_inv)
        direct.append(np.sqrt(0.5 * np.trace(p @ c @ p @ c)))
        restricted.append(
            -0.5 * (-np.linalg.slogdet(v_inv)[1] + np.linalg.slogdet(m)[1] + y @ p @ y)
        )
    np.testing.assert_allclose(_reference_prior(t, u, q), direct, rtol=1e-9)
    loglik = kalman_filter(t, y, u, q)[2]
    np.testing.assert_allclose(np.diff(loglik), np.diff(restricted), rtol=1e-9, atol=1e-9)


def test_missing_uncertainty_and_too_few_runs_are_refused():
    dates = [START + timedelta(days=i) for i in range(5)]
    with pytest.raises(InputError, match="E_X0C: every calibration needs its standard"):
        fit_drift("E_X0C", "µm", dates, np.zeros(5), np.full(5, np.nan))
    with pytest.raises(InputError, match="at least 4 calibrations, got 3"):
        fit_drift("E_X0C", "µm", dates[:3], np.zeros(3), np.ones(3))
    with pytest.raises(InputError, match="unbounded from 4 calibrations"):
        fit_drift("E_X0C", "µm", dates[:4], np.zeros(4), np.ones(4))
    assert fit_drift("E_X0C", "µm", dates[:4], np.zeros(4), np.ones(4), prior="half-cauchy")
    with pytest.raises(InputError, match="prior 'flat'"):
        fit_drift("E_X0C", "µm", dates, np.zeros(5), np.ones(5), prior="flat")
