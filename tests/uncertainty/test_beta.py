"""The Beta distribution of the uncertainty engine against scipy.stats.beta."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from mtmetrology.uncertainty import Beta
from mtmetrology.uncertainty.distributions import make_distribution

CASES = [(-2.0, 3.0, 2.0, 5.0), (0.0, 1.0, 0.5, 0.5), (10.0, 12.0, 4.0, 4.0), (-1, 1, 1, 1)]


@pytest.mark.parametrize("low, high, a, b", CASES)
def test_moments_equal_scipy(low, high, a, b):
    ref = stats.beta(a, b, loc=low, scale=high - low)
    d = Beta(low, high, a, b)
    assert d.mean == pytest.approx(ref.mean(), rel=1e-13, abs=1e-13)
    assert d.standard_uncertainty == pytest.approx(ref.std(), rel=1e-13)


@pytest.mark.parametrize("low, high, a, b", CASES)
def test_samples_follow_scipy_cdf(low, high, a, b):
    """Kolmogorov–Smirnov against scipy's cdf, 20 000 draws, seed fixed: a correct sampler
    fails at the 0.1 % level once in a thousand seeds; a wrong shape or support fails."""
    x = Beta(low, high, a, b).sample(np.random.default_rng(7), 20_000)
    assert stats.kstest(x, stats.beta(a, b, loc=low, scale=high - low).cdf).pvalue > 1e-3
    assert x.min() >= low and x.max() <= high


def test_swapped_shapes_fail_the_ks_test():
    """The test above can fail: alpha and beta swapped is rejected."""
    x = Beta(0.0, 1.0, 5.0, 2.0).sample(np.random.default_rng(7), 20_000)
    assert stats.kstest(x, stats.beta(2.0, 5.0).cdf).pvalue < 1e-6


def test_registry_accepts_both_forms():
    a = make_distribution("beta", low=-1.0, high=3.0, alpha=2.0, beta=3.0)
    b = make_distribution("beta", x=1.0, a=2.0, alpha=2.0, beta=3.0)
    assert a == b == Beta(-1.0, 3.0, 2.0, 3.0)


@pytest.mark.parametrize(
    "kwargs, word",
    [
        ({"low": 0, "high": 1, "alpha": 0.0, "beta": 1}, "alpha"),
        ({"low": 0, "high": 1, "alpha": 1, "beta": -2}, "beta"),
        ({"low": 1, "high": 1, "alpha": 1, "beta": 1}, "high"),
        ({"low": 0, "high": float("nan"), "alpha": 1, "beta": 1}, "high"),
    ],
)
def test_bad_parameters_named(kwargs, word):
    with pytest.raises(ValueError) as err:
        Beta(**kwargs)
    assert str(err.value).split()[0] == word
