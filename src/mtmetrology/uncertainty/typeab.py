"""Type A and Type B evaluation of standard uncertainty (JCGM 100:2008, §4.2 and §4.3).

Type A: statistics of repeated indications.  Type B: conversions of stated
information (certificates, limits, resolution, length-dependent specifications)
to a standard uncertainty.  All functions work in the units of their arguments.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

__all__ = [
    "PooledStd",
    "TypeA",
    "arcsine_u",
    "expanded_to_u",
    "pooled_std",
    "rectangular_u",
    "resolution_u",
    "spec_linear",
    "spec_quadrature",
    "triangular_u",
    "type_a",
    "type_a_pooled",
]


@dataclass(frozen=True)
class TypeA:
    """Type A evaluation of n indications.

    Attributes
    ----------
    mean : float
        Arithmetic mean q̄ (JCGM 100, 4.2.1).
    std : float
        Experimental standard deviation s(q_k) of one indication (4.2.2).
    u : float
        Standard uncertainty of the mean s(q̄) = s/√n (4.2.3).
    dof : float
        ν = n − 1, or the pooled dof (4.2.4).
    n : int
    message : str
    """

    mean: float
    std: float
    u: float
    dof: float
    n: int
    message: str


@dataclass(frozen=True)
class PooledStd:
    """Pooled experimental standard deviation s_p with ν = Σ(n_i − 1) (JCGM 100, 4.2.4)."""

    std: float
    dof: float
    message: str


def _indications(values, name: str = "values", minimum: int = 2) -> np.ndarray:
    q = np.asarray(values, dtype=float).ravel()
    if q.size < minimum:
        raise ValueError(f"{name} needs at least {minimum} indications, got {q.size}")
    if not np.all(np.isfinite(q)):
        raise ValueError(f"{name} contains {np.count_nonzero(~np.isfinite(q))} NaN/inf")
    return q


def type_a(values: Sequence[float]) -> TypeA:
    """Mean, experimental standard deviation, s/√n and ν = n − 1 of n indications.

    Parameters
    ----------
    values : (n,) array_like, n >= 2

    Returns
    -------
    TypeA

    Notes
    -----
    s²(q_k) = Σ(q_k − q̄)²/(n − 1), u(q̄) = s(q_k)/√n (JCGM 100:2008, 4.2.2–4.2.3).

    Examples
    --------
    >>> r = type_a([10.1, 10.3, 10.2])
    >>> round(r.mean, 6), round(r.std, 6), r.dof
    (10.2, 0.1, 2.0)
    """
    q = _indications(values)
    s = float(q.std(ddof=1))
    n = q.size
    return TypeA(
        float(q.mean()), s, s / math.sqrt(n), float(n - 1), n, f"{n} indications, dof {n - 1}"
    )


def pooled_std(groups: Sequence[Sequence[float]]) -> PooledStd:
    """Pooled standard deviation of several series of the same process (JCGM 100, 4.2.4).

    Notes
    -----
    s_p² = Σ_i (n_i − 1) s_i² / Σ_i (n_i − 1), ν = Σ_i (n_i − 1).
    """
    series = [_indications(g, f"groups[{i}]") for i, g in enumerate(groups)]
    if not series:
        raise ValueError("groups must contain at least one series")
    dof = sum(g.size - 1 for g in series)
    ss = sum(float(np.sum((g - g.mean()) ** 2)) for g in series)
    return PooledStd(math.sqrt(ss / dof), float(dof), f"{len(series)} series, dof {dof}")


def type_a_pooled(values: Sequence[float], pooled: PooledStd) -> TypeA:
    """Mean of n new indications with the pooled s_p: u = s_p/√n, ν = ν_p (JCGM 100, 4.2.4)."""
    q = _indications(values, minimum=1)
    n = q.size
    return TypeA(
        float(q.mean()),
        pooled.std,
        pooled.std / math.sqrt(n),
        pooled.dof,
        n,
        f"{n} indications with pooled s (dof {pooled.dof:g})",
    )


def _positive(name: str, value) -> float:
    v = float(value)
    if not math.isfinite(v) or v < 0:
        raise ValueError(f"{name} must be finite and >= 0, got {value}")
    return v


def expanded_to_u(
    U: float, k: float | None = None, *, p: float | None = None, dof: float = math.inf
) -> float:
    """Standard uncertainty from a certificate's expanded uncertainty (JCGM 100, 4.3.3–4.3.4).

    Parameters
    ----------
    U : float
        Expanded uncertainty.
    k : float, optional
        Stated coverage factor; u = U/k.
    p, dof : float, optional
        If only a coverage probability is stated, k is the t (normal for
        dof = inf) quantile t_{(1+p)/2, ν}.
    """
    U = _positive("U", U)
    if (k is None) == (p is None):
        raise ValueError("give exactly one of k or p")
    if k is not None:
        k = float(k)
        if not k > 0:
            raise ValueError(f"k must be > 0, got {k}")
        return U / k
    if not 0 < p < 1:
        raise ValueError(f"p must lie in (0, 1), got {p}")
    q = (1.0 + p) / 2.0
    k = stats.norm.ppf(q) if math.isinf(dof) else stats.t.ppf(q, dof)
    return U / float(k)


def rectangular_u(a: float) -> float:
    """u = a/√3 for a quantity within ±a, no value favoured (JCGM 100, 4.3.7)."""
    return _positive("a", a) / math.sqrt(3.0)


def triangular_u(a: float) -> float:
    """u = a/√6 for a symmetric triangular distribution of half-width a (JCGM 100, 4.3.9)."""
    return _positive("a", a) / math.sqrt(6.0)


def arcsine_u(a: float) -> float:
    """u = a/√2 for a U-shaped (arcsine) distribution of half-width a (JCGM 101, 6.4.6)."""
    return _positive("a", a) / math.sqrt(2.0)


def resolution_u(resolution: float) -> float:
    """u = r/(2√3) for a digital indication with resolution r (JCGM 100, F.2.2.1)."""
    return _positive("resolution", resolution) / (2.0 * math.sqrt(3.0))


def spec_linear(a: float, b: float, length):
    """A length-dependent specification a + b·|L| (e.g. MPE = 0.6 µm + L/600, L in mm).

    Parameters
    ----------
    a : float
        Constant term (unit of the result).
    b : float
        Slope (unit of the result per unit of ``length``).
    length : float or array_like
        Measured length(s) L.

    Examples
    --------
    >>> round(float(spec_linear(0.6, 1 / 600, 300.0)), 6)   # µm, with L = 300 mm
    1.1
    """
    a, b = _positive("a", a), _positive("b", b)
    return a + b * np.abs(np.asarray(length, dtype=float))


def spec_quadrature(a: float, b: float, length):
    """A length-dependent specification sqrt(a² + (b·L)²) (e.g. U = sqrt(0.52² + (1.4e-3 L)²)).

    Examples
    --------
    >>> round(float(spec_quadrature(0.52, 1.4e-3, 1000.0)), 4)
    1.4935
    """
    a, b = _positive("a", a), _positive("b", b)
    return np.hypot(a, b * np.asarray(length, dtype=float))
