"""Tests for mtmetrology.uncertainty.distributions."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mtmetrology.uncertainty.distributions import (
    DISTRIBUTION_KINDS,
    Arcsine,
    CurvilinearTrapezoid,
    MultivariateNormal,
    MultivariateT,
    Normal,
    Rectangular,
    Samples,
    StudentT,
    Trapezoidal,
    Triangular,
    make_distribution,
    psd_factor,
)

N_DRAWS = 400_000

UNIVARIATE = [
    Normal(3.0, 0.5),
    Rectangular(-1.0, 3.0),
    Triangular(0.0, 1.0, 2.0),
    Triangular(0.0, 0.2, 2.0),  # asymmetric
    Trapezoidal(-2.0, 2.0, 0.4),
    CurvilinearTrapezoid(-1.0, 1.0, 0.3),
    Arcsine(10.0, 12.0),
    StudentT(5.0, 0.2, 7.0),
    Samples(np.array([1.0, 2.0, 2.0, 5.0, 9.0])),
]


@pytest.mark.parametrize("dist", UNIVARIATE, ids=lambda d: type(d).__name__)
def test_sample_moments_match_mean_and_standard_uncertainty(dist):
    """Sample mean and std agree with .mean / .standard_uncertainty.

    Tolerance: 5 standard errors.  s.e.(mean) = u/√n; s.e.(std) <= u·sqrt((κ−1)/(4n))
    with kurtosis κ <= 6 for these distributions (t_7 has κ = 3 + 6/3 = 5), i.e. < 1.2 u/√n.
    """
    rng = np.random.default_rng(20260101)
    x = dist.sample(rng, N_DRAWS)
    u = dist.standard_uncertainty
    se = u / math.sqrt(N_DRAWS)
    assert x.shape == (N_DRAWS,)
    assert abs(x.mean() - dist.mean) < 5 * se
    assert abs(x.std() - u) < 5 * 1.2 * se


def test_closed_form_moments():
    """JCGM 101 6.4: rectangular a/√3, arcsine a/√2, trapezoid, curvilinear, t."""
    assert Rectangular(-1, 1).standard_uncertainty == pytest.approx(1 / math.sqrt(3))
    assert Arcsine(-1, 1).standard_uncertainty == pytest.approx(1 / math.sqrt(2))
    assert Triangular(-1, 0, 1).standard_uncertainty == pytest.approx(1 / math.sqrt(6))
    assert Trapezoidal(-1, 1, 0).standard_uncertainty == pytest.approx(1 / math.sqrt(6))
    assert Trapezoidal(-1, 1, 1).standard_uncertainty == pytest.approx(1 / math.sqrt(3))
    assert CurvilinearTrapezoid(-1, 1, 0.3).standard_uncertainty == pytest.approx(
        math.sqrt(1 / 3 + 0.09 / 9)
    )
    assert StudentT(0, 2.0, 4).standard_uncertainty == pytest.approx(2.0 * math.sqrt(2.0))
    assert StudentT(0, 1.0, 2).standard_uncertainty == math.inf
    tri = Triangular(0.0, 0.2, 2.0)
    assert tri.mean == pytest.approx(2.2 / 3)


def test_bounded_samples_stay_within_limits():
    rng = np.random.default_rng(1)
    for dist in (
        Rectangular(-1, 3),
        Triangular(0, 0.2, 2),
        Trapezoidal(-2, 2, 0.4),
        Arcsine(10, 12),
    ):
        x = dist.sample(rng, 10_000)
        assert x.min() >= dist.low and x.max() <= dist.high
    x = CurvilinearTrapezoid(-1.0, 1.0, 0.3).sample(rng, 10_000)
    assert x.min() >= -1.3 and x.max() <= 1.3


def test_sum_of_two_equal_rectangulars_is_triangular():
    """Exact: R(−a, a) + R(−a, a) is triangular on [−2a, 2a]; compare CDF at 0 and ±a."""
    rng = np.random.default_rng(7)
    a = 0.5
    s = Rectangular(-a, a).sample(rng, 200_000) + Rectangular(-a, a).sample(rng, 200_000)
    # Triangular CDF on [−1, 1]: F(−0.5) = 0.125, F(0) = 0.5, F(0.5) = 0.875.
    # Binomial s.e. <= 0.5/√2e5 = 0.0011; tolerance 0.005 is > 4 s.e.
    for t, f in ((-0.5, 0.125), (0.0, 0.5), (0.5, 0.875)):
        assert np.mean(s <= t) == pytest.approx(f, abs=0.005)


def test_samples_resampling_uses_only_given_values():
    d = Samples([1.0, 2.0, 4.0])
    x = d.sample(np.random.default_rng(3), 1000)
    assert set(np.unique(x)) <= {1.0, 2.0, 4.0}
    assert d.standard_uncertainty == pytest.approx(np.std([1.0, 2.0, 4.0]))


def test_multivariate_normal_singular_covariance_with_zero_variance_row():
    """Rank-deficient covariance (x3 = x1 + x2/4) and a constant coordinate (zero row)."""
    a = np.array([[1.0, 0.0], [0.0, 4.0], [1.0, 1.0]])
    cov = np.zeros((4, 4))
    cov[:3, :3] = a @ np.diag([0.25, 0.09]) @ a.T  # rank 2
    mean = np.array([1.0, -2.0, 0.5, 7.0])
    d = MultivariateNormal(mean, cov)
    x = d.sample(np.random.default_rng(11), 200_000)
    assert x.shape == (200_000, 4)
    assert np.all(x[:, 3] == 7.0)  # zero variance: exactly constant
    np.testing.assert_allclose(
        x[:, 2] - mean[2], (x[:, 0] - mean[0]) + (x[:, 1] - mean[1]) / 4, atol=1e-12
    )
    # Sample covariance: relative s.e. of a variance is sqrt(2/n) = 0.3 %; 2 % tolerance.
    np.testing.assert_allclose(np.cov(x.T), cov, rtol=0.02, atol=0.02 * cov.max())
    np.testing.assert_allclose(d.standard_uncertainty, np.sqrt(np.diag(cov)))
    # The transposed layout draws the same stream (InputSet writes it into its columns).
    t = d.sample_transposed(np.random.default_rng(11), 200_000)
    assert t.shape == (4, 200_000) and t.flags.c_contiguous
    np.testing.assert_allclose(t, x.T, rtol=0, atol=1e-12)


def test_from_replicates_reproduces_sample_covariance_rank_k_minus_1():
    """K = 5 replicates of N = 8 coordinates: covariance of rank 4 = np.cov of the replicates."""
    rng = np.random.default_rng(5)
    reps = rng.normal(size=(5, 8)) * np.arange(1, 9)
    d = MultivariateNormal.from_replicates(reps)
    np.testing.assert_allclose(d.covariance, np.cov(reps.T), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(d.mean, reps.mean(axis=0))
    assert np.linalg.matrix_rank(d.covariance) == 4
    x = d.sample(np.random.default_rng(6), 300_000)
    # Draws lie in the affine span of the replicates (rank K − 1).
    centred = x - reps.mean(axis=0)
    assert np.linalg.matrix_rank(centred[:50], tol=1e-8) == 4
    np.testing.assert_allclose(
        np.cov(x.T), np.cov(reps.T), rtol=0.03, atol=0.03 * np.cov(reps.T).max()
    )


def test_multivariate_t_covariance_is_nu_over_nu_minus_2_scale():
    scale = np.array([[1.0, 0.3], [0.3, 2.0]])
    d = MultivariateT([0.0, 1.0], scale, 6.0)
    np.testing.assert_allclose(d.covariance, 1.5 * scale)
    x = d.sample(np.random.default_rng(8), 400_000)
    # t_6 has heavy tails (κ = 6): the variance estimate has relative s.e. ~ sqrt(5/n) = 0.35 %.
    np.testing.assert_allclose(np.cov(x.T), 1.5 * scale, rtol=0.03, atol=0.03)
    np.testing.assert_allclose(x.mean(axis=0), [0.0, 1.0], atol=0.01)


def test_psd_factor_reconstructs_and_rejects_non_psd():
    c = np.array([[4.0, 2.0], [2.0, 1.0]])  # singular
    s = psd_factor(c)
    np.testing.assert_allclose(s @ s.T, c, atol=1e-12)
    with pytest.raises(ValueError, match="not positive semidefinite: smallest eigenvalue"):
        psd_factor(np.array([[1.0, 2.0], [2.0, 1.0]]))
    with pytest.raises(ValueError, match="zero-variance row"):
        psd_factor(np.array([[0.0, 0.1], [0.1, 1.0]]))
    with pytest.raises(ValueError, match="symmetric"):
        psd_factor(np.array([[1.0, 0.5], [0.1, 1.0]]))


@settings(max_examples=30, deadline=None)
@given(st.integers(1, 6), st.integers(2, 9), st.integers(0, 2**32 - 1))
def test_psd_factor_round_trip_any_rank(rank, n, seed):
    """S Sᵀ reproduces any PSD matrix of any rank."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(n, min(rank, n)))
    c = a @ a.T
    s = psd_factor(c)
    np.testing.assert_allclose(s @ s.T, c, atol=1e-9 * max(1.0, np.abs(c).max()))


def test_registry_builds_every_kind_and_forms():
    assert make_distribution("normal", x=1.0, u=0.1) == Normal(1.0, 0.1)
    assert make_distribution("normal", x=1.0, U=0.2, k=2).u == pytest.approx(0.1)
    assert make_distribution("rectangular", x=1.0, a=0.5) == Rectangular(0.5, 1.5)
    assert make_distribution("Rectangular", low=0.5, high=1.5) == Rectangular(0.5, 1.5)
    assert make_distribution("triangular", x=0.0, a=1.0) == Triangular(-1.0, 0.0, 1.0)
    assert make_distribution("triangular", low=0, mode=0.2, high=1).mode == 0.2
    assert make_distribution("trapezoidal", x=0, a=1, beta=0.5) == Trapezoidal(-1, 1, 0.5)
    assert make_distribution("curvilinear_trapezoid", x=0, a=1, d=0.1).d == 0.1
    assert make_distribution("arcsine", x=0, a=2) == Arcsine(-2, 2)
    assert make_distribution("student-t", x=0, s=1, dof=5).dof == 5
    assert make_distribution("samples", values=[1, 2]).mean == 1.5
    assert (
        make_distribution("multivariate-normal", mean=[0, 0], covariance=np.eye(2)).dimension == 2
    )
    assert make_distribution("multivariate-t", mean=[0], scale=[[1.0]], dof=5).dimension == 1
    assert make_distribution("beta", x=0, a=1, alpha=2, beta=2).alpha == 2
    assert len(DISTRIBUTION_KINDS) == 11


def test_unknown_distribution_lists_known_kinds():
    with pytest.raises(
        ValueError, match=r"unknown distribution 'gaussian'; known kinds: normal, rectangular"
    ):
        make_distribution("gaussian", x=0, u=1)


def test_missing_and_unexpected_parameters_are_named():
    with pytest.raises(ValueError, match=r"missing parameter 'u'.*x, u  or  x, U, k"):
        make_distribution("normal", x=0)
    with pytest.raises(ValueError, match=r"unexpected parameter\(s\) \['sigma'\]"):
        make_distribution("normal", x=0, u=1, sigma=2)
    with pytest.raises(ValueError, match=r"takes parameters \(low, high\) or \(x, a\)"):
        make_distribution("rectangular", x=0, high=1)


@pytest.mark.parametrize(
    ("build", "message"),
    [
        (lambda: Normal(0.0, -1.0), "u must be >= 0"),
        (lambda: Normal(float("nan"), 1.0), "x must be finite"),
        (lambda: Normal(0.0, float("nan")), "u must be finite"),
        (lambda: Rectangular(2.0, 1.0), r"high \(1.0\) must be >= low \(2.0\)"),
        (lambda: make_distribution("rectangular", x=0, a=-1), "a must be >= 0"),
        (lambda: Triangular(0, 3, 2), "mode"),
        (lambda: Trapezoidal(0, 1, 1.5), "beta must lie in"),
        (lambda: CurvilinearTrapezoid(0, 1, 0.6), "d .* must not exceed the half-width"),
        (lambda: StudentT(0, 1, 0), "dof must be > 0"),
        (lambda: StudentT(0, -1, 3), "s must be >= 0"),
        (lambda: Samples([1.0, float("nan")]), "values contains 1 NaN"),
        (
            lambda: MultivariateNormal([0, 0], [[1, 2], [2, 1]]),
            "covariance is not positive semidefinite",
        ),
        (lambda: MultivariateNormal([0, float("nan")], np.eye(2)), "mean contains NaN"),
        (lambda: MultivariateT([0], [[1.0]], -1), "dof must be > 0"),
        (lambda: make_distribution("normal", x=0, U=1, k=0), "k must be > 0"),
    ],
)
def test_invalid_parameters_give_clear_errors(build, message):
    with pytest.raises(ValueError, match=message):
        build()


@pytest.mark.parametrize(
    "distribution",
    [
        Normal(3.0, 0.7),
        Rectangular(-1.3, 2.9),
        StudentT(5.0, 0.2, 7.0),
        Triangular(0.0, 1.0, 3.0),
        Arcsine(-2.0, 2.0),
    ],
)
def test_sample_into_draws_the_numbers_of_sample(distribution):
    """The in-place draw used by InputSet.sample gives bit-identical values to sample()."""
    expected = distribution.sample(np.random.default_rng(5), 1000)
    out = np.empty(1000)
    distribution.sample_into(np.random.default_rng(5), out)
    np.testing.assert_array_equal(out, expected)
