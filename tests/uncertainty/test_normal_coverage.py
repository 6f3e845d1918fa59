"""k and p of the coverage region of n normal quantities (JCGM 102:2011, 6.5.2.3)."""

import pytest
from scipy import stats

from mtmetrology.uncertainty.normal_coverage import normal_region_coverage


@pytest.mark.parametrize("n", [1, 2, 3, 6, 13])
def test_region_coverage_k_and_p_are_inverse_and_chi2(n):
    """JCGM 102 6.5.2.3: p = P(χ²_n ≤ k²); k from p and p from k are inverse."""
    for p in (0.6827, 0.95, 0.9545, 0.99):
        r = normal_region_coverage(n, p=p)
        assert (r.dimension, r.coverage_probability) == (n, p)
        assert stats.chi2.cdf(r.coverage_factor**2, n) == pytest.approx(p, abs=1e-12)
        back = normal_region_coverage(n, k=r.coverage_factor)
        assert back.coverage_probability == pytest.approx(p, abs=1e-12)
    # n = 1 is the interval y ± k u: p = 2 Φ(k) − 1
    if n == 1:
        assert normal_region_coverage(1, k=2.0).coverage_probability == pytest.approx(
            2 * stats.norm.cdf(2.0) - 1, abs=1e-15
        )


def test_region_coverage_of_13_parameters_and_refusals():
    assert normal_region_coverage(13, k=2.0).coverage_probability == pytest.approx(
        0.009, abs=5e-4
    )  # the one-parameter k covers 0.9 % of a 13-parameter region (issue 30)
    assert normal_region_coverage(13, p=0.95).coverage_factor == pytest.approx(4.7289, abs=1e-4)
    for bad in ({}, {"p": 0.95, "k": 2.0}, {"p": 1.0}, {"k": -1.0}, {"k": float("nan")}):
        with pytest.raises(ValueError):
            normal_region_coverage(3, **bad)
    with pytest.raises(ValueError, match="positive number of quantities"):
        normal_region_coverage(0, p=0.95)
