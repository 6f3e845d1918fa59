"""Tests for drift removal and sliding-window repeatability (Sepahi Boroujeni (2021), §4).

T22 of the test plan: cubic detrending brings the standard deviation of a series with a
cubic drift down to the white-noise level.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats as sps

from mtmetrology.errors import InputError
from mtmetrology.omm.drift import detrend_cubic, sliding_window_std
from mtmetrology.omm.repeatability import target_statistics
from mtmetrology.omm.repeatability_windows import window_statistics
from mtmetrology.units import to_internal

UM = to_internal(1.0, "µm")


def _cubic(t, c):
    return c[0] + c[1] * t + c[2] * t**2 + c[3] * t**3


def test_exact_cubic_leaves_zero_residuals_against_index_and_time():
    t = np.arange(50.0)
    y = 28.78 + _cubic(t / 50, [0.0, 3.0, -5.0, 2.5]) * UM
    assert np.max(np.abs(detrend_cubic(y))) < 1e-12
    # Unequally spaced times (a shuffled test): a cubic in time is no cubic in the index.
    times = np.sort(np.random.default_rng(1).uniform(0, 3600, 50))
    y_time = 28.78 + _cubic(times / 3600, [0.0, 4.0, -6.0, 3.0]) * UM
    assert np.max(np.abs(detrend_cubic(y_time, times))) < 1e-12
    assert np.max(np.abs(detrend_cubic(y_time))) > 0.01 * UM


def test_residuals_are_invariant_to_the_unit_and_origin_of_time():
    rng = np.random.default_rng(2)
    t = np.sort(rng.uniform(0, 100, 20))
    y = rng.normal(size=(20, 3))
    r1 = detrend_cubic(y, t)
    r2 = detrend_cubic(y, 60.0 * t + 1.0e5)
    assert np.allclose(r1, r2, rtol=0, atol=1e-12)
    assert np.allclose(r1.sum(axis=0), 0.0, atol=1e-12)  # the constant is fitted


def test_t22_detrended_s_is_consistent_with_the_white_noise_and_raw_s_is_not():
    """300 series of 50: cubic drift of a few µm plus white noise σ = 0.5 µm.

    Pooled (n − 4) s²/σ² over the series is χ² with 300·46 degrees of freedom for the
    detrended s (two-sided test at level 1 %); the raw s (drift included) fails the
    upper bound of the same test with n − 1.
    """
    rng = np.random.default_rng(22)
    n, series, sigma = 50, 300, 0.5 * UM
    t = np.arange(n, dtype=float)
    detrended, raw = np.empty(series), np.empty(series)
    for j in range(series):
        c = rng.uniform(-1, 1, 4) * np.array([5.0, 6.0, 6.0, 6.0]) * UM
        y = _cubic(t / n, c) + rng.normal(0.0, sigma, n)
        r = detrend_cubic(y, t)
        detrended[j] = np.sum(r**2) / (n - 4)
        raw[j] = np.var(y, ddof=1)
    dof = series * (n - 4)
    statistic = np.sum((n - 4) * detrended) / sigma**2
    assert sps.chi2.ppf(0.005, dof) < statistic < sps.chi2.ppf(0.995, dof)
    raw_statistic = np.sum((n - 1) * raw) / sigma**2
    assert raw_statistic > sps.chi2.ppf(0.995, series * (n - 1))


def test_target_statistics_with_cubic_drift_use_n_minus_4_degrees_of_freedom():
    """200 targets, 30 usable touches, isotropic noise σ = 0.4 µm on a cubic drift in time.

    The pooled σ_X² over the targets is consistent with σ² (χ² with 200·26 dof, level
    1 %); ddof = 1 instead of 4 would bias it by 26/29 (five standard deviations).
    """
    rng = np.random.default_rng(7)
    n_t, touches, sigma = 200, 31, 0.4 * UM
    names, readings, times = [], [], []
    for k in range(n_t):
        time = np.sort(rng.uniform(0, 18000, touches))
        drift = np.column_stack(
            [_cubic(time / 18000, rng.uniform(-3, 3, 4) * UM) for _ in range(3)]
        )
        readings.append(drift + rng.normal(0, sigma, (touches, 3)))
        names += [f"t{k}"] * touches
        times.append(time)
    st = target_statistics(
        names,
        np.zeros((n_t * touches, 7)),
        np.vstack(readings),
        np.tile([0.0, 0.0, 1.0], (n_t * touches, 1)),
        np.concatenate(times),
        drift="cubic",
    )
    assert st.drift == "cubic" and np.all(st.n_touches == touches - 1)
    dof = n_t * (touches - 1 - 4)
    for j in range(3):  # X, Y, Z
        statistic = (touches - 1 - 4) * np.sum(st.std[:, j] ** 2) / sigma**2
        assert sps.chi2.ppf(0.005 / 3, dof) < statistic < sps.chi2.ppf(1 - 0.005 / 3, dof)
    assert np.all(st.std_raw[:, :3].mean(axis=0) > 2 * sigma)  # the drift dominates raw s
    doc = st.to_dict()
    assert doc["drift"] == {"model": "cubic", "abscissa": "time", "ddof": 4}
    assert "sigma_X_raw" in doc["targets"][0]


def test_cubic_drift_needs_six_usable_touches():
    def stats(touches):
        return target_statistics(
            ["a"] * touches,
            np.zeros((touches, 7)),
            np.random.default_rng(0).normal(size=(touches, 3)),
            np.tile([1.0, 0.0, 0.0], (touches, 1)),
            np.arange(float(touches)),
            drift="cubic",
        )

    with pytest.raises(InputError, match="at least 6"):
        stats(6)  # 5 usable after the first is discarded
    assert stats(7).n_touches[0] == 6
    with pytest.raises(InputError, match="drift"):
        target_statistics(["a"] * 4, np.zeros((4, 7)), np.zeros((4, 3)), np.zeros((4, 3)),
                          np.arange(4.0), drift="linear")  # fmt: skip


def test_drift_fit_refuses_repeated_times():
    with pytest.raises(InputError, match="distinct times"):
        detrend_cubic(np.arange(8.0), [0.0, 0.0, 1.0, 1.0, 2.0, 2.0, 2.0, 2.0])


def test_sliding_window_finds_a_change_of_noise_level():
    """Noise σ₁ = 0.3 µm for touches 1–30, σ₂ = 1.2 µm from touch 31 on (100 targets).

    Windows of 10 wholly before the change (start ≤ 21) have a pooled s² consistent with
    σ₁², wholly after it (start ≥ 31) with σ₂²: χ² with 100·9 dof, two-sided, level 1 %
    per window family (Bonferroni over the windows tested).
    """
    rng = np.random.default_rng(20)
    n_t, touches, window = 100, 60, 10
    s1, s2 = 0.3 * UM, 1.2 * UM
    level = np.where(np.arange(touches) < 30, s1, s2)
    readings = rng.normal(0.0, 1.0, (n_t, touches, 3)) * level[None, :, None]
    ws = window_statistics(
        np.repeat([f"t{k}" for k in range(n_t)], touches),
        readings.reshape(-1, 3),
        np.tile([0.0, 0.0, 1.0], (n_t * touches, 1)),
        np.tile(np.arange(float(touches)), n_t),
        window=window,
        first_iteration=2,
    )
    starts = ws.starts[0]
    assert starts.tolist() == list(range(2, touches - window + 2))
    pooled = np.mean([s[:, 0] ** 2 for s in ws.std], axis=0)  # σ_X² per window start
    before, after = starts <= 21, starts >= 31
    m = before.sum() + after.sum()
    dof = n_t * (window - 1)
    lo, hi = sps.chi2.ppf(0.005 / m, dof) / dof, sps.chi2.ppf(1 - 0.005 / m, dof) / dof
    assert np.all((lo < pooled[before] / s1**2) & (pooled[before] / s1**2 < hi))
    assert np.all((lo < pooled[after] / s2**2) & (pooled[after] / s2**2 < hi))
    # N = reading · n̂ = Z here: its windows equal those of Z.
    assert np.allclose(ws.std[0][:, 3], ws.std[0][:, 2])


def test_window_larger_than_the_series_is_refused_naming_the_target():
    readings = np.zeros((12, 3))
    args = (["a"] * 12, readings, np.tile([1.0, 0, 0], (12, 1)), np.arange(12.0))
    assert len(window_statistics(*args, window=11).starts[0]) == 1
    with pytest.raises(InputError, match="'a'"):
        window_statistics(*args, window=12)  # from iteration 2: 11 touches left
    with pytest.raises(InputError, match="window"):
        sliding_window_std(np.zeros(5), 1)
    with pytest.raises(InputError, match="first iteration"):
        window_statistics(*args, first_iteration=0)


def test_repeated_times_are_refused_naming_the_target():
    touches = 8
    time = np.r_[np.arange(float(touches)), np.zeros(touches)]  # target "b": one instant
    with pytest.raises(InputError, match="'b'"):
        target_statistics(
            ["a"] * touches + ["b"] * touches,
            np.zeros((2 * touches, 7)),
            np.random.default_rng(3).normal(size=(2 * touches, 3)),
            np.tile([1.0, 0.0, 0.0], (2 * touches, 1)),
            time,
            drift="cubic",
        )
