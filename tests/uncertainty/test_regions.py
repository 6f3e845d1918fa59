"""Coverage intervals and regions from samples (JCGM 101 §7.7, JCGM 102 §7.7;
the pairwise areas of Sepahi Boroujeni 2021, Ch. 5 and 7)."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from mtmetrology.uncertainty.regions import (
    coverage_index,
    coverage_intervals,
    ellipse_area,
    ellipsoidal_coverage_factor,
    histogram,
    intervals_and_histograms,
    normal_ellipsoidal_coverage_factor,
    normal_rectangular_coverage_factor,
    pairwise_areas,
    rectangle_area,
    rectangular_coverage_factor,
    shortest_interval,
    smallest_region,
    symmetric_interval,
)


def test_coverage_index_follows_jcgm101_7_7_1():
    """q = pM when pM is an integer, else the integer part of pM + 1/2."""
    assert coverage_index(10_000, 0.95) == 9500
    assert coverage_index(10_001, 0.95) == 9501  # 9500.95 + 0.5 -> 9501
    assert coverage_index(1_000_003, 0.95) == 950_003  # 950002.85 + 0.5 -> 950003
    assert coverage_index(20, 0.95) == 19  # one value left outside: the least M allows
    with pytest.raises(ValueError, match="too few"):
        coverage_index(10, 0.95)  # 9.5 + 0.5 -> q = 10 = M: nothing outside


def test_symmetric_interval_takes_the_order_statistics_of_jcgm101_7_7_2():
    """M = 10 000 values 1..M: q = 9500, r = 250, interval [ỹ_(250), ỹ_(9750)] = [250, 9750]."""
    values = np.random.default_rng(0).permutation(np.arange(1.0, 10_001.0))
    np.testing.assert_array_equal(symmetric_interval(values, 0.95), [250.0, 9750.0])
    # M - q odd: M = 10 001, q = 9501, r = (500 + 1)/2 = 250 (1-based).
    values = np.arange(1.0, 10_002.0)
    np.testing.assert_array_equal(symmetric_interval(values, 0.95), [250.0, 9751.0])


def test_shortest_interval_of_exponential_is_strictly_shorter():
    """Exp(1): shortest 95 % interval [0, −ln 0.05] (length 2.996) against the symmetric
    [−ln 0.975, −ln 0.025] (length 3.664). M = 10⁵; the end quantiles have standard
    deviations of about sqrt(p(1 − p)/M)/f ≈ 0.02 at the upper end, so 0.08 is 4σ."""
    sample = np.random.default_rng(1).exponential(1.0, 100_000)
    symmetric, shortest = coverage_intervals(sample, 0.95)
    np.testing.assert_allclose(symmetric, [-np.log(0.975), -np.log(0.025)], atol=0.08)
    np.testing.assert_allclose(shortest, [0.0, -np.log(0.05)], atol=0.08)
    assert np.ptp(shortest) < np.ptp(symmetric) - 0.5


def test_shortest_and_symmetric_agree_for_a_normal_sample():
    """For a symmetric unimodal PDF both are y ± 1.96 u; with M = 10⁵ the ends move by
    ≈ 0.006 u (standard deviation), the difference between the two by less than 0.03 u."""
    sample = np.random.default_rng(2).normal(5.0, 2.0, 100_000)
    symmetric, shortest = coverage_intervals(sample, 0.95)
    np.testing.assert_allclose(symmetric, 5.0 + np.array([-1.96, 1.96]) * 2.0, atol=0.06)
    np.testing.assert_allclose(shortest, symmetric, atol=0.06)


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    trials=st.integers(60, 3000),
    p=st.sampled_from([0.5, 0.9, 0.95]),
    shift=st.floats(-1e3, 1e3),
    scale=st.floats(1e-3, 1e3),
)
def test_intervals_are_equivariant_and_shortest_is_never_longer(seed, trials, p, shift, scale):
    """Invariances: the shortest interval is a candidate-minimum, so never longer than the
    symmetric one; both move with an increasing affine map of the values."""
    rng = np.random.default_rng(seed)
    sample = np.column_stack([rng.gamma(2.0, size=trials), rng.normal(size=trials)])
    symmetric, shortest = coverage_intervals(sample, p)
    assert np.all(np.ptp(shortest, axis=1) <= np.ptp(symmetric, axis=1))
    moved_symmetric, moved_shortest = coverage_intervals(shift + scale * sample, p)
    np.testing.assert_allclose(moved_symmetric, shift + scale * symmetric, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(
        np.ptp(moved_shortest, axis=1), scale * np.ptp(shortest, axis=1), rtol=1e-9, atol=1e-9
    )


def test_normal_coverage_factors_reproduce_sepahi_boroujeni():
    """Sepahi Boroujeni (2021), Table 5-3 and Ch. 7: k_p = 1.96, 2.4477, 3.55, 4.73 for m = 1, 2,
    6, 13 (p = 0.95);
    k_q = 2.2365 (independent) and 2.2414 (Bonferroni) for m = 2."""
    values = [normal_ellipsoidal_coverage_factor(m) for m in (1, 2, 6, 13)]
    np.testing.assert_allclose(values, [1.96, 2.4477, 3.5485, 4.7289], atol=5e-4)
    assert normal_rectangular_coverage_factor(2, independent=True) == pytest.approx(
        2.2365, abs=1e-4
    )
    assert normal_rectangular_coverage_factor(2) == pytest.approx(2.2414, abs=1e-4)
    assert normal_rectangular_coverage_factor(1, independent=True) == pytest.approx(1.96, abs=1e-3)


def test_pairwise_area_formulas_reproduce_digest_000_table():
    """Sepahi Boroujeni (2021), Ch. 5: E_XX1–E_YY1 (u 6.1, 5.4 µm/m, ρ 0.965) ellipse 162.6,
    Bonferroni
    rectangle 662 (thesis 657.3); Ch. 7 point 1 X–Y (u 6.7, 8.2 µm, ρ = −1.7/√(4.5·6.6))
    ellipse 982.5 µm² (thesis smallest region 982.8 µm²)."""
    k2 = normal_ellipsoidal_coverage_factor(2)
    assert ellipse_area(k2, 6.1, 5.4, 0.965) == pytest.approx(162.6, abs=0.05)
    assert rectangle_area(normal_rectangular_coverage_factor(2), 6.1, 5.4) == pytest.approx(
        662.0, abs=0.1
    )
    rho = -1.7 / np.sqrt(4.5 * 6.6)
    assert ellipse_area(k2, 6.7, 8.2, rho) == pytest.approx(982.5, abs=0.05)
    assert ellipse_area(k2, 6.7, 8.2, rho) == pytest.approx(982.8, rel=0.001)
    with pytest.raises(ValueError, match="correlation"):
        ellipse_area(k2, 1.0, 1.0, 1.5)


def test_sample_ellipsoidal_factor_tends_to_chi2_for_multivariate_normal():
    """JCGM 102 7.7.2 on N(0, Σ) with m = 3: k_p → sqrt(χ²_3(0.95)) = 2.7955. At M = 10⁵
    the quantile of d has a standard deviation of about 0.005; tolerance 0.02."""
    rng = np.random.default_rng(3)
    covariance = np.array([[4.0, 1.2, -0.5], [1.2, 1.0, 0.1], [-0.5, 0.1, 0.25]])
    sample = rng.multivariate_normal([1.0, -2.0, 3.0], covariance, size=100_000)
    k_p = ellipsoidal_coverage_factor(sample, 0.95)
    assert k_p == pytest.approx(np.sqrt(stats.chi2.ppf(0.95, 3)), abs=0.02)
    # The exact covariance and mean give the same factor within the same noise.
    k_exact = ellipsoidal_coverage_factor(
        sample, 0.95, estimate=[1.0, -2.0, 3.0], covariance=covariance
    )
    assert k_exact == pytest.approx(k_p, abs=0.02)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), entries=st.lists(st.floats(-3, 3), min_size=4, max_size=4))
def test_ellipsoidal_factor_is_invariant_under_linear_maps(seed, entries):
    """d_r² is invariant under y -> B y for non-singular B (sample mean and covariance
    transform with B), so k_p is unchanged."""
    transform = np.array(entries).reshape(2, 2) + 4 * np.eye(2)
    sample = np.random.default_rng(seed).standard_t(5, size=(500, 2))
    k_p = ellipsoidal_coverage_factor(sample, 0.9)
    assert ellipsoidal_coverage_factor(sample @ transform.T, 0.9) == pytest.approx(k_p, rel=1e-8)


def test_sample_regions_of_bivariate_normal_agree_with_theory():
    """Sepahi Boroujeni (2021), Ch. 7 areas on N(0, diag(u1², u2²)) with u = (6.7, 8.2), M = 4·10⁵:
    ellipse π k_p² u1 u2 (k_p² = 5.9915), rectangle 4 k_q² u1 u2 with k_q → 2.2365
    (independent outputs), and the meshed smallest region not larger than the ellipse
    (it is the ellipse for a normal PDF) within the mesh and count noise of about 1 %."""
    rng = np.random.default_rng(4)
    sample = rng.normal(0.0, [6.7, 8.2], size=(400_000, 2))
    areas = pairwise_areas(sample, 0, 1, 0.95)
    exact_ellipse = np.pi * stats.chi2.ppf(0.95, 2) * 6.7 * 8.2
    exact_rectangle = 4 * 2.2364766**2 * 6.7 * 8.2
    assert areas.ellipse == pytest.approx(exact_ellipse, rel=0.015)
    assert areas.rectangle == pytest.approx(exact_rectangle, rel=0.015)
    assert areas.rectangular_coverage_factor == pytest.approx(2.2365, abs=0.01)
    assert areas.correlation == pytest.approx(0.0, abs=0.01)
    assert areas.smallest <= areas.ellipse * 1.02
    assert areas.smallest == pytest.approx(exact_ellipse, rel=0.03)
    assert areas.ellipse < areas.rectangle


def test_correlated_pair_ellipse_area_matches_formula_and_smallest_region():
    """ρ = −0.31 (the point-1 X–Y pair of Sepahi Boroujeni 2021, Ch. 7): the sample ellipse area
    matches
    π k_p² u1 u2 sqrt(1 − ρ²) = 982.5 µm² within 1.5 %; the smallest region within 3 %."""
    rho = -1.7 / np.sqrt(4.5 * 6.6)
    covariance = np.array([[6.7**2, rho * 6.7 * 8.2], [rho * 6.7 * 8.2, 8.2**2]])
    sample = np.random.default_rng(5).multivariate_normal([0, 0], covariance, size=400_000)
    areas = pairwise_areas(sample, 0, 1)
    assert areas.ellipse == pytest.approx(982.5, rel=0.015)
    assert areas.smallest == pytest.approx(982.5, rel=0.03)


def test_smallest_region_of_a_bimodal_sample_is_smaller_than_the_ellipse():
    """Two separated clusters: the ellipse covers the empty middle, the mesh does not."""
    rng = np.random.default_rng(6)
    centres = np.where(rng.random(200_000) < 0.5, -5.0, 5.0)
    sample = np.column_stack([centres + rng.normal(size=200_000), rng.normal(size=200_000)])
    region = smallest_region(sample, 0.95)
    k_p = ellipsoidal_coverage_factor(sample, 0.95)
    u = sample.std(axis=0, ddof=1)
    assert region.volume < 0.5 * ellipse_area(k_p, u[0], u[1], 0.0)
    assert region.probability >= 0.95
    assert region.mask.shape == (len(region.edges[0]) - 1, len(region.edges[1]) - 1)


def test_rectangular_factor_of_one_output_is_the_symmetric_half_width():
    """m = 1: k_q is the 95 % quantile of |y − ȳ|/u, 1.96 for a normal sample (±0.02)."""
    sample = np.random.default_rng(7).normal(size=100_000)
    assert rectangular_coverage_factor(sample, 0.95) == pytest.approx(1.96, abs=0.02)
    assert ellipsoidal_coverage_factor(sample, 0.95) == pytest.approx(1.96, abs=0.02)


def test_histogram_density_integrates_to_one():
    sample = np.random.default_rng(8).normal(size=10_000)
    result = histogram(sample, 50)
    assert np.sum(result.values * np.diff(result.edges)) == pytest.approx(1.0)
    assert result.centres.shape == (50,)
    counts = histogram(sample, 50, density=False)
    assert counts.values.sum() == 10_000


@pytest.mark.parametrize(
    ("call", "match"),
    [
        (lambda: symmetric_interval(np.ones(100), 1.0), "p must lie"),
        (lambda: shortest_interval(np.ones(100), 0.0), "p must lie"),
        (lambda: symmetric_interval([1.0, np.nan, 2.0] * 50, 0.9), "NaN"),
        (lambda: symmetric_interval(np.ones((10, 2, 2)), 0.9), "shape"),
        (lambda: symmetric_interval([1.0], 0.9), "at least 2"),
        (lambda: ellipsoidal_coverage_factor(np.ones((100, 2)), 0.9), "zero variance"),
        (lambda: rectangular_coverage_factor(np.ones((100, 2)), 0.9), "zero"),
        (lambda: smallest_region(np.ones((100, 2)), 0.9), "no spread"),
        (lambda: pairwise_areas(np.zeros((100, 2)), 0, 0), "two different"),
        (lambda: normal_ellipsoidal_coverage_factor(0), "positive number"),
        (lambda: histogram(np.ones((3, 2))), "one-dimensional"),
    ],
)
def test_bad_input_is_refused_with_a_named_reason(call, match):
    with pytest.raises(ValueError, match=match):
        call()


def _full_sort_intervals(y: np.ndarray, p: float):
    """JCGM 101:2008, 7.7 literally: sort everything, r and q as in the clause."""
    ordered = np.sort(y, axis=0)
    trials, m = y.shape
    q = coverage_index(trials, p)
    r = (trials - q) // 2 if (trials - q) % 2 == 0 else (trials - q + 1) // 2
    symmetric = np.stack([ordered[r - 1], ordered[r - 1 + q]], axis=-1)
    start = np.argmin(ordered[q:] - ordered[:-q], axis=0)
    columns = np.arange(m)
    shortest = np.stack([ordered[start, columns], ordered[start + q, columns]], axis=-1)
    return symmetric, shortest


@settings(max_examples=40, deadline=None)
@given(
    st.integers(200, 20_000),
    st.integers(1, 3),
    st.sampled_from(["t", "discrete", "constant", "narrow"]),
    st.sampled_from([0.3, 0.5, 0.9, 0.95, 0.99]),
    st.integers(0, 2**32 - 1),
)
def test_tail_selection_equals_the_full_sort(trials, m, kind, p, seed):
    """The binned tail selection gives the very order statistics of a full sort, for heavy
    tails, ties (discrete values), constants and spreads of a few ulps; the histogram from
    the same binning matches numpy's for continuous and discrete samples."""
    rng = np.random.default_rng(seed)
    y = {
        "t": lambda: rng.standard_t(3, size=(trials, m)),
        "discrete": lambda: rng.integers(0, 5, size=(trials, m)).astype(float),
        "constant": lambda: np.full((trials, m), 2.5),
        "narrow": lambda: 5e7 + 1e-8 * rng.standard_normal((trials, m)),
    }[kind]()
    symmetric, shortest, histograms = intervals_and_histograms(y, p, 100)
    exact_symmetric, exact_shortest = _full_sort_intervals(y, p)
    np.testing.assert_array_equal(symmetric, exact_symmetric)
    np.testing.assert_array_equal(shortest, exact_shortest)
    for j, h in enumerate(histograms):
        assert np.all(np.isfinite(h.values))
        assert np.sum(h.values * np.diff(h.edges)) == pytest.approx(1.0)
        if kind in ("t", "discrete"):
            values, edges = np.histogram(y[:, j], 100, density=True)
            np.testing.assert_allclose(h.edges, edges)
            # Values within rounding of an inner edge may change bin: at most a few trials.
            assert np.abs(h.values - values).sum() * np.diff(edges)[0] <= 5 / trials
