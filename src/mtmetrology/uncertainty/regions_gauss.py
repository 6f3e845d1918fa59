"""Coverage factors and 2-D region areas for Gaussian outputs (JCGM 102:2011, §6.5).

These are the GUF (normal-output) counterparts of the sample-based regions of
Monte Carlo: hyper-ellipsoid k_p = sqrt(χ²_m(p)), hyper-rectangle factors, and
the pairwise areas that seed 000 compares (digest 000 §3.7).
"""

from __future__ import annotations

import math

from scipy import stats

__all__ = [
    "bonferroni_coverage_factor",
    "ellipse_area",
    "ellipsoid_coverage_factor",
    "independent_rectangular_factor",
    "rectangle_area",
]


def _check(m: int, p: float) -> None:
    if int(m) != m or m < 1:
        raise ValueError(f"m must be a positive integer, got {m}")
    if not 0.0 < p < 1.0:
        raise ValueError(f"p must lie in (0, 1), got {p}")


def ellipsoid_coverage_factor(m: int, p: float = 0.95) -> float:
    """k_p = sqrt(χ²_m(p)) for the hyper-ellipsoid (y−η)ᵀU_y⁻¹(y−η) <= k_p² (JCGM 102, 6.5.2).

    Examples
    --------
    >>> [round(ellipsoid_coverage_factor(m), 2) for m in (1, 6, 13)]
    [1.96, 3.55, 4.73]
    """
    _check(m, p)
    return math.sqrt(stats.chi2.ppf(p, m))


def bonferroni_coverage_factor(m: int, p: float = 0.95) -> float:
    """k_q = Φ⁻¹(1 − (1 − p)/(2m)): a hyper-rectangle valid for any correlation (conservative).

    Notes
    -----
    Bonferroni's inequality bounds the probability that any of the m marginal
    intervals y_j ± k_q u(y_j) is missed by m·(1 − p)/m = 1 − p (digest 000 §3.7;
    JCGM 102:2011, 6.5.4 notes the rectangle for correlated outputs).
    """
    _check(m, p)
    return float(stats.norm.ppf(1.0 - (1.0 - p) / (2.0 * m)))


def independent_rectangular_factor(m: int, p: float = 0.95) -> float:
    """k_q = Φ⁻¹((1 + p^{1/m})/2): exact hyper-rectangle factor for independent normal outputs."""
    _check(m, p)
    return float(stats.norm.ppf(0.5 * (1.0 + p ** (1.0 / m))))


def ellipse_area(u1: float, u2: float, rho: float, p: float = 0.95) -> float:
    """Area π k_p² u₁ u₂ sqrt(1 − ρ²) of the 2-D coverage ellipse, k_p² = χ²_2(p).

    Parameters
    ----------
    u1, u2 : float
        Standard uncertainties of the two outputs (area in the product of their units).
    rho : float
        Correlation coefficient in [−1, 1].

    Notes
    -----
    The ellipse xᵀU⁻¹x <= k² has area π k² sqrt(det U) and det U = u₁²u₂²(1 − ρ²)
    (digest 000 §3.7).
    """
    if u1 < 0 or u2 < 0:
        raise ValueError(f"u1 and u2 must be >= 0, got {u1}, {u2}")
    if not -1.0 <= rho <= 1.0:
        raise ValueError(f"rho must lie in [-1, 1], got {rho}")
    return math.pi * ellipsoid_coverage_factor(2, p) ** 2 * u1 * u2 * math.sqrt(1.0 - rho**2)


def rectangle_area(u1: float, u2: float, k_q: float) -> float:
    """Area (2 k_q u₁)(2 k_q u₂) of the 2-D coverage rectangle."""
    if u1 < 0 or u2 < 0 or k_q < 0:
        raise ValueError(f"u1, u2 and k_q must be >= 0, got {u1}, {u2}, {k_q}")
    return 4.0 * k_q**2 * u1 * u2
