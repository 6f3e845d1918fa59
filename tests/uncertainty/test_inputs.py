"""Tests for mtmetrology.uncertainty.inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.uncertainty.distributions import Normal, Rectangular, StudentT
from mtmetrology.uncertainty.inputs import InputQuantity, InputSet


def _set(correlation=None):
    qs = [
        InputQuantity("a", Normal(1.0, 0.2), "mm"),
        InputQuantity("b", Normal(-2.0, 0.5), "µm", dof=12),
        InputQuantity("c", Rectangular(0.0, 1.0), "°C"),
        InputQuantity("t", StudentT(3.0, 0.1, 9.0), "µm/m"),
    ]
    return InputSet(qs, correlation)


def test_estimates_uncertainties_units_and_dof():
    s = _set()
    assert s.names == ["a", "b", "c", "t"]
    assert s.units == ["mm", "µm", "°C", "µm/m"]
    np.testing.assert_allclose(s.estimate, [1.0, -2.0, 0.5, 3.0])
    np.testing.assert_allclose(
        s.standard_uncertainty, [0.2, 0.5, 1 / math.sqrt(12), 0.1 * math.sqrt(9 / 7)]
    )
    np.testing.assert_allclose(s.covariance, np.diag(s.standard_uncertainty**2))
    # dof: inf when not given; a Student-t input carries its own ν.
    np.testing.assert_array_equal(s.dof, [math.inf, 12.0, math.inf, 9.0])


def test_correlated_normals_are_sampled_jointly_with_the_stated_covariance():
    r = np.eye(4)
    r[0, 1] = r[1, 0] = -0.8
    s = _set(r)
    expected_cov = -0.8 * 0.2 * 0.5
    assert s.covariance[0, 1] == pytest.approx(expected_cov)
    x = s.sample(np.random.default_rng(2), 200_000)
    assert x.shape == (200_000, 4)
    # s.e. of a correlation estimate ≈ (1 − ρ²)/√n = 0.0008; tolerance 0.005.
    assert np.corrcoef(x[:, 0], x[:, 1])[0, 1] == pytest.approx(-0.8, abs=0.005)
    assert abs(np.corrcoef(x[:, 0], x[:, 2])[0, 1]) < 0.01
    # Means within 5 standard errors u/√n.
    assert np.all(np.abs(x.mean(axis=0) - s.estimate) < 5 * s.standard_uncertainty / math.sqrt(2e5))


def test_from_covariance_handles_zero_variance_inputs():
    """The 1-D example of Sepahi Boroujeni (2021), Ch. 6 plus a constant input."""
    cov = np.array([[2.0e-6, -1.0e-8, 0.0], [-1.0e-8, 1.0e-10, 0.0], [0.0, 0.0, 0.0]])
    s = InputSet.from_covariance(
        ["gamma", "delta", "B"], [100.0, -50e-6, 30.0], cov, ["mm", "1", "deg"]
    )
    np.testing.assert_allclose(s.covariance, cov, rtol=1e-12, atol=1e-24)
    x = s.sample(np.random.default_rng(4), 50_000)
    assert np.all(x[:, 2] == 30.0)
    assert np.corrcoef(x[:, 0], x[:, 1])[0, 1] == pytest.approx(-1e-8 / math.sqrt(2e-16), abs=0.02)


def test_sampling_is_reproducible_for_a_seeded_generator():
    s = _set()
    a = s.sample(np.random.default_rng(99), 10)
    b = s.sample(np.random.default_rng(99), 10)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(s.sample(99, 10), s.sample(99, 10))  # an int seed works too


def test_bad_unit_names_the_input():
    with pytest.raises(ValueError, match=r"input 'a': unknown unit 'furlong'"):
        InputQuantity("a", Normal(0, 1), "furlong")


def test_non_normal_correlation_is_refused_with_reason():
    r = np.eye(4)
    r[0, 2] = r[2, 0] = 0.5
    with pytest.raises(
        ValueError, match=r"'c' is Rectangular; correlations are supported between normal"
    ):
        _set(r)


def _chain(r01, r12, r02):
    m = np.eye(4)
    m[0, 1] = m[1, 0] = r01
    m[1, 2] = m[2, 1] = r12
    m[0, 2] = m[2, 0] = r02
    return m


@pytest.mark.parametrize(
    ("matrix", "message"),
    [
        (np.full((4, 4), 0.5), "unit diagonal"),
        (np.eye(3), r"shape \(4, 4\)"),
        (_chain(1.2, 0.0, 0.0), r"must lie in \[-1, 1\]"),
        (_chain(0.5, 0.0, float("nan")), "NaN"),
        # ρ01 = ρ12 = 0.9 forces ρ02 >= 0.62; ρ02 = 0 gives eigenvalue 1 − 0.9·√2 < 0.
        (_chain(0.9, 0.9, 0.0), "correlation is not positive semidefinite"),
    ],
)
def test_bad_correlation_matrices(matrix, message):
    quantities = [InputQuantity(n, Normal(0, 1)) for n in "abcd"]
    with pytest.raises(ValueError, match=message):
        InputSet(quantities, matrix)


def test_duplicate_names_and_bad_dof():
    with pytest.raises(ValueError, match=r"duplicate input names: \['a'\]"):
        InputSet([InputQuantity("a", Normal(0, 1)), InputQuantity("a", Normal(0, 1))])
    with pytest.raises(ValueError, match=r"input 'a': dof must be > 0"):
        InputQuantity("a", Normal(0, 1), dof=-2)
    with pytest.raises(ValueError, match="univariate Distribution"):
        InputQuantity("a", 3.0)


def test_from_observations_is_jcgm100_type_a_with_one_ensemble():
    """JCGM 100:2008, 4.2 and 5.2.3 (eq. 17) written out term by term: means, covariances
    of the means s(q̄_i, q̄_j) = Σ_k (q_ik − q̄_i)(q_jk − q̄_j)/(n(n − 1)), ν = n − 1, and
    all inputs in ensemble 0 (GUM H.2 data, Table H.2)."""
    obs = [[5.007, 19.663, 1.0456], [4.994, 19.639, 1.0438], [5.005, 19.640, 1.0468],
           [4.990, 19.685, 1.0428], [4.999, 19.678, 1.0433]]  # fmt: skip
    s = InputSet.from_observations(["V", "I", "phi"], obs, ["", "", "rad"])
    n = len(obs)
    means = [sum(row[i] for row in obs) / n for i in range(3)]
    for i in range(3):
        for j in range(3):
            expected = sum((row[i] - means[i]) * (row[j] - means[j]) for row in obs) / (n * (n - 1))
            assert s.covariance[i, j] == pytest.approx(expected, rel=1e-12)
    np.testing.assert_allclose(s.estimate, means, rtol=1e-15)
    # Published (JCGM 100:2008, Table H.3): s(V̄) = 0.0032 V, s(Ī) = 0.0095 mA, s(φ̄) = 0.00075 rad.
    np.testing.assert_allclose(s.standard_uncertainty, [0.0032, 0.0095, 0.00075], atol=5e-5)
    assert s.dof.tolist() == [4.0, 4.0, 4.0] and s.ensemble.tolist() == [0, 0, 0]


@pytest.mark.parametrize(
    ("build", "match"),
    [
        (lambda: InputSet.from_observations(["a", "b"], [[1.0, 2.0]]), r"shape \(n >= 2, 2\)"),
        (lambda: InputSet.from_observations(["a"], [[1.0], [2.0], [3.0], [np.nan]]), "NaN"),
        (lambda: _pair(ensembles=[["a", "zz"]]), "unknown inputs"),
        (lambda: _pair(ensembles=[["a"], ["a", "b"]]), "more than one ensemble"),
        (lambda: _pair(dof=(4, 5), ensembles=[["a", "b"]]), "share one finite"),
        (lambda: _pair(dof=(None, None), ensembles=[["a", "b"]]), "share one finite"),
    ],
)
def test_bad_observations_and_ensembles_are_refused(build, match):
    with pytest.raises(InputError, match=match):
        build()


def _pair(dof=(4, 4), ensembles=()):
    return InputSet(
        [InputQuantity("a", Normal(0.0, 1.0), dof=dof[0]),
         InputQuantity("b", Normal(0.0, 1.0), dof=dof[1])],
        ensembles=ensembles,
    )  # fmt: skip


def test_runs_of_normals_draw_the_same_numbers_as_one_draw_per_input():
    """Consecutive independent normals are drawn in one call: the stream is consumed in
    the same order as input by input (each input's ``size`` draws in turn), so the
    samples equal those of each distribution's own ``sample`` on the same generator."""
    dists = [Normal(1.0, 0.1), Normal(-2.0, 0.3), Rectangular(0.0, 1.0)]
    dists += [Normal(float(k), 0.2 + k) for k in range(4)] + [StudentT(0.0, 1.0, 5)]
    inputs = InputSet([InputQuantity(f"q{k}", d) for k, d in enumerate(dists)])
    got = inputs.sample(np.random.default_rng(9), 257)
    rng = np.random.default_rng(9)
    expected = np.column_stack([d.sample(rng, 257) for d in dists])
    assert np.array_equal(got, expected)
