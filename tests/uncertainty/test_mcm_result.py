"""Tests for mtmetrology.uncertainty.mcm_result (MCMResult and summarise)."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.uncertainty.mcm_result import HISTOGRAM_BINS, summarise
from mtmetrology.uncertainty.sample_statistics import Moments

RUN = dict(
    trials=10_000,
    sequences=1,
    converged=None,
    tolerance=None,
    criterion=None,
    checks=(),
    scalar_model=False,
    message="10000 trials, 2 outputs",
)


def _result(values, keep_samples=False, p=0.95):
    moments = Moments()
    moments.add(values)
    labels = (None, ["mm", "µm"], ["a", "b"], None)
    return summarise(values, moments, p, labels, keep_samples=keep_samples, **RUN)


@pytest.fixture(scope="module")
def values():
    rng = np.random.default_rng(7)
    return np.column_stack([rng.normal(1.0, 0.5, 10_000), rng.uniform(-1.0, 1.0, 10_000)])


def test_summary_statistics_are_those_of_the_sample(values):
    r = _result(values)
    np.testing.assert_allclose(r.estimate, values.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(r.covariance, np.cov(values.T), rtol=1e-10)
    np.testing.assert_allclose(r.standard_uncertainty, values.std(axis=0, ddof=1), rtol=1e-10)
    assert r.names == ("a", "b") and r.units == ("mm", "µm")
    assert r.largest_eigenvalue == pytest.approx(np.linalg.eigvalsh(np.corrcoef(values.T))[-1])


def test_expanded_uncertainty_is_half_the_symmetric_interval(values):
    """U = half-width of the probabilistically symmetric interval, k = U/u (JCGM 101 7.7)."""
    r = _result(values)
    lo, hi = np.quantile(values, [0.025, 0.975], axis=0, method="inverted_cdf")
    np.testing.assert_allclose(r.interval[:, 0], lo, atol=1e-3)
    np.testing.assert_allclose(r.interval[:, 1], hi, atol=1e-3)
    np.testing.assert_allclose(r.expanded_uncertainty, 0.5 * (r.interval[:, 1] - r.interval[:, 0]))
    np.testing.assert_allclose(r.coverage_factor, r.expanded_uncertainty / r.standard_uncertainty)
    # a rectangular output: shortest interval is not shorter than 95 % of the range,
    # and a normal output's k is near 1.96
    assert r.coverage_factor[0] == pytest.approx(1.96, abs=0.05)
    assert r.coverage_factor[1] == pytest.approx(0.95 * np.sqrt(3), abs=0.03)
    width = r.interval_shortest[:, 1] - r.interval_shortest[:, 0]
    assert np.all(width <= r.interval[:, 1] - r.interval[:, 0] + 1e-12)


def test_zero_variance_output_has_nan_coverage_factor():
    values = np.column_stack([np.linspace(0.0, 1.0, 201), np.full(201, 3.0)])
    r = _result(values)
    assert r.standard_uncertainty[1] == 0.0
    assert np.isnan(r.coverage_factor[1]) and np.isfinite(r.coverage_factor[0])


def test_arrays_are_read_only(values):
    r = _result(values, keep_samples=True)
    for array in (r.estimate, r.covariance, r.interval, r.interval_shortest, r.samples):
        with pytest.raises(ValueError):
            array[0] = 0.0


def test_stored_histogram_and_recomputed_histogram(values):
    r = _result(values, keep_samples=True)
    stored = r.histogram(1)
    assert stored.values.size == HISTOGRAM_BINS and stored.density
    assert np.sum(stored.values * np.diff(stored.edges)) == pytest.approx(1.0)
    counts = r.histogram(1, bins=10, density=False)
    assert counts.values.sum() == values.shape[0] and counts.values.size == 10


def test_histogram_and_areas_without_samples_are_refused(values):
    r = _result(values)
    with pytest.raises(ValueError) as info:
        r.histogram(0, bins=20)
    assert str(info.value) == "other bins need the samples: run monte_carlo(keep_samples=True)"
    with pytest.raises(ValueError) as info:
        r.histogram(2)
    assert str(info.value) == "output must be in 0..1, got 2"
    with pytest.raises(ValueError) as info:
        r.pairwise_areas(0, 1)
    assert str(info.value) == (
        "pairwise areas need the samples: run monte_carlo(keep_samples=True)"
    )


def test_to_dict_carries_the_run_and_shortest_intervals(values):
    r = _result(values)
    d = r.to_dict()
    for key in ("trials", "sequences", "converged", "criterion", "tolerance", "message"):
        assert d[key] == RUN[key]
    assert d["checks"] == []
    assert "samples" not in d and "histograms" not in d
    assert d["method"] == "mcm"
    assert d["interval_shortest"] == r.interval_shortest.tolist()
    assert [o["name"] for o in d["outputs"]] == ["a", "b"]
