"""Streaming moments, correlation and joint coverage factors of Monte Carlo values."""

import numpy as np
import pytest

from mtmetrology.uncertainty.inputs import InputSet
from mtmetrology.uncertainty.mcm import monte_carlo
from mtmetrology.uncertainty.sample_statistics import (
    Moments,
    correlation_matrix,
    joint_coverage_factors,
)

SUM_INPUTS = InputSet.from_covariance(
    ["x0", "x1", "x2"], [1.0, 2.0, -1.0], np.diag([0.1, 0.2, 0.3]) ** 2
)


def test_streaming_moments_equal_the_direct_sample_moments():
    result = monte_carlo(
        lambda x: x[:, :2] * 1e6 + 5e7,  # large offset: a naive Σy² formula would lose digits
        SUM_INPUTS,
        trials=30_000,
        chunk_size=7_000,
        seed=27,
        keep_samples=True,
    )
    np.testing.assert_allclose(result.estimate, result.samples.mean(axis=0), rtol=1e-14)
    np.testing.assert_allclose(result.covariance, np.cov(result.samples.T), rtol=1e-10)


@pytest.mark.parametrize("cuts", [[1], [3, 4], [2, 5, 6]])
def test_moments_do_not_depend_on_how_the_values_are_cut(cuts):
    values = np.random.default_rng(4).normal(size=(7, 3))
    moments = Moments()
    for block in np.split(values, cuts):
        moments.add(block)
    assert moments.count == 7
    np.testing.assert_allclose(moments.mean, values.mean(axis=0), rtol=1e-14)
    np.testing.assert_allclose(moments.covariance, np.cov(values.T), rtol=1e-12)


def test_correlation_of_a_constant_output_is_zero_with_a_unit_diagonal():
    r = correlation_matrix(np.array([[4.0, 3.0, 0.0], [3.0, 9.0, 0.0], [0.0, 0.0, 0.0]]))
    np.testing.assert_allclose(r, [[1.0, 0.5, 0.0], [0.5, 1.0, 0.0], [0.0, 0.0, 1.0]])


def test_joint_factors_skip_constant_outputs_and_single_outputs():
    """Two independent standard normals and a constant: k_p² → χ²₂(0.95) = 5.99 (the
    constant adds no dimension); one output has no joint factors."""
    values = np.random.default_rng(8).normal(size=(100_000, 3))
    values[:, 2] = 1.5
    mean, cov = values.mean(axis=0), np.cov(values.T)
    k_p, k_q = joint_coverage_factors(values, mean, cov, 0.95)
    assert k_p**2 == pytest.approx(5.991, rel=0.02)
    assert k_q == pytest.approx(2.236, rel=0.02)  # Φ⁻¹((1 + √0.95)/2) for two outputs
    assert joint_coverage_factors(values[:, :1], mean[:1], cov[:1, :1], 0.95) == (None, None)
