"""Coverage factor and coverage probability of the region of n normal quantities.

One function, :func:`normal_region_coverage`, for every coverage region of several
quantities that mtmetrology states (the GUF's hyper-ellipsoid, the DCC's
``ellipsoidalRegionXMLList``, the ellipse plots): for an n-variate normal output the
hyper-ellipsoid ``(y − ŷ)ᵀ U_y⁻¹ (y − ŷ) ≤ k²`` holds it with probability
``p = P(χ²_n ≤ k²)`` (JCGM 102:2011, 6.5.2.3), so k and p are stated together, for their n.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["RegionCoverage", "normal_region_coverage"]


@dataclass(frozen=True)
class RegionCoverage:
    """Coverage factor and coverage probability of the hyper-ellipsoidal region of n
    normal quantities, consistent for n: ``p = P(χ²_n ≤ k²)`` (:func:`normal_region_coverage`).

    Attributes
    ----------
    dimension : int
        Number n of quantities the region covers jointly.
    coverage_factor : float
        k: the region is ``(y − ŷ)ᵀ U_y⁻¹ (y − ŷ) ≤ k²``.
    coverage_probability : float
        p, the probability that the region holds the quantities.
    """

    dimension: int
    coverage_factor: float
    coverage_probability: float

    def to_dict(self) -> dict:
        """``dimension``, ``coverage_factor``, ``coverage_probability``, ``distribution``."""
        return {
            "dimension": self.dimension,
            "coverage_factor": self.coverage_factor,
            "coverage_probability": self.coverage_probability,
            "distribution": "normal",
        }


def normal_region_coverage(
    n: int, *, p: float | None = None, k: float | None = None
) -> RegionCoverage:
    """k for a coverage probability p, or p for a coverage factor k, of n normal quantities.

    The one function for every coverage region of several quantities that mtmetrology
    states (GUF results, the DCC's ``ellipsoidalRegionXMLList``, ellipse plots): the region
    ``(y − ŷ)ᵀ U_y⁻¹ (y − ŷ) ≤ k²`` of an n-variate normal output holds it with probability

        p = P(χ²_n ≤ k²),        k = sqrt(χ²_n⁻¹(p))

    (JCGM 102:2011, 6.5.2.3 and 6.5.3). For n = 1 it is the interval y ± k u with
    p = 2 Φ(k) − 1; for n = 13 the one-parameter k = 2 covers 0.9 % and p = 0.9545 needs
    k = 4.76.

    Parameters
    ----------
    n : int
        Number of quantities, >= 1.
    p : float, optional
        Coverage probability, 0 < p < 1.
    k : float, optional
        Coverage factor, > 0. Give exactly one of ``p`` and ``k``.

    Returns
    -------
    RegionCoverage

    Raises
    ------
    ValueError
        n < 1, neither or both of p and k, p outside (0, 1), k not a positive number.

    Notes
    -----
    Sepahi Boroujeni (2021), Table 5-3 and Ch. 7: k = 1.96, 2.4477, 3.5485, 4.7289 for
    n = 1, 2, 6, 13 and p = 0.95.

    Examples
    --------
    >>> r = normal_region_coverage(13, p=0.9545)
    >>> round(r.coverage_factor, 2)
    4.76
    >>> round(normal_region_coverage(1, k=2.0).coverage_probability, 4)
    0.9545
    """
    from scipy import stats  # here, not at the top: importing it takes 0.5 s

    if isinstance(n, bool) or int(n) != n or int(n) < 1:
        raise ValueError(f"n must be a positive number of quantities, got {n}")
    n = int(n)
    if (p is None) == (k is None):
        raise ValueError("give exactly one of the coverage probability p and the factor k")
    if p is not None:
        p = float(p)
        if not 0.0 < p < 1.0:
            raise ValueError(f"p must lie strictly between 0 and 1, got {p}")
        return RegionCoverage(n, float(np.sqrt(stats.chi2.ppf(p, n))), p)
    k = float(k)
    if not (math.isfinite(k) and k > 0):
        raise ValueError(f"k must be a positive number, got {k}")
    return RegionCoverage(n, k, float(stats.chi2.cdf(k * k, n)))
