"""Probability distributions for input quantities (JCGM 101:2008 §6, JCGM 102:2011 §5).

Every distribution exposes ``.mean``, ``.standard_uncertainty`` and
``.sample(rng, size)``; univariate ones return samples of shape ``size`` and
multivariate ones ``(size, N)``.  Parameters are validated at construction: a NaN,
an infinite value, a negative width or uncertainty raises :class:`ValueError`
naming the parameter.

Model files create distributions by name through :func:`make_distribution`; the
registry accepts either limits (``low``, ``high``) or a centre and half-width
(``x``, ``a``) for the bounded distributions.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "DISTRIBUTION_KINDS",
    "Arcsine",
    "Beta",
    "CurvilinearTrapezoid",
    "Distribution",
    "MultivariateNormal",
    "MultivariateT",
    "Normal",
    "Rectangular",
    "Samples",
    "StudentT",
    "Trapezoidal",
    "Triangular",
    "make_distribution",
    "psd_factor",
]

Size = int | tuple[int, ...]


def _finite(name: str, value) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {v}")
    return v


def _nonnegative(name: str, value) -> float:
    v = _finite(name, value)
    if v < 0:
        raise ValueError(f"{name} must be >= 0, got {v}")
    return v


def _limits(low, high) -> tuple[float, float]:
    lo, hi = _finite("low", low), _finite("high", high)
    if hi < lo:
        raise ValueError(f"high ({hi}) must be >= low ({lo})")
    return lo, hi


class Distribution:
    """Common interface: ``mean``, ``standard_uncertainty``, ``sample(rng, size)``."""

    #: True for distributions of a vector quantity (samples of shape (size, N)).
    multivariate = False

    @property
    def mean(self):  # pragma: no cover - every subclass defines it
        raise NotImplementedError

    @property
    def standard_uncertainty(self):  # pragma: no cover - every subclass defines it
        raise NotImplementedError

    @property
    def variance(self):
        """Square of the standard uncertainty."""
        return np.square(self.standard_uncertainty)

    def sample(self, rng: np.random.Generator, size: Size) -> np.ndarray:  # pragma: no cover
        raise NotImplementedError

    def sample_into(self, rng: np.random.Generator, out: np.ndarray) -> None:
        """Draw ``out.shape[0]`` values into the contiguous 1-D array ``out``.

        The same values as ``sample(rng, out.size)``; distributions that can draw in place
        override it to spare the temporaries (Monte Carlo draws millions of values).
        """
        out[...] = self.sample(rng, out.shape[0])


@dataclass(frozen=True)
class Normal(Distribution):
    """Gaussian N(x, u²) (JCGM 101:2008, 6.4.7).

    Parameters
    ----------
    x : float
        Expectation (the estimate).
    u : float
        Standard deviation, >= 0 (u = 0 is a constant).
    """

    x: float
    u: float

    def __post_init__(self):
        object.__setattr__(self, "x", _finite("x", self.x))
        object.__setattr__(self, "u", _nonnegative("u", self.u))

    @property
    def mean(self) -> float:
        return self.x

    @property
    def standard_uncertainty(self) -> float:
        return self.u

    def sample(self, rng, size):
        return rng.normal(self.x, self.u, size)

    def sample_into(self, rng, out):
        # The same numbers as sample(): numpy's normal is loc + scale·z of the same z.
        rng.standard_normal(out=out)
        out *= self.u
        out += self.x


@dataclass(frozen=True)
class _SymmetricInterval(Distribution):
    """A distribution symmetric about the centre of [low, high]: E = (low + high)/2."""

    low: float
    high: float

    def __post_init__(self):
        lo, hi = _limits(self.low, self.high)
        object.__setattr__(self, "low", lo)
        object.__setattr__(self, "high", hi)

    @property
    def mean(self) -> float:
        return 0.5 * (self.low + self.high)


@dataclass(frozen=True)
class Rectangular(_SymmetricInterval):
    """Uniform on [low, high] (JCGM 101:2008, 6.4.2).

    Notes
    -----
    E = (low + high)/2, u = (high − low)/√12 = a/√3 with half-width a.
    """

    @property
    def standard_uncertainty(self) -> float:
        return (self.high - self.low) / math.sqrt(12.0)

    def sample(self, rng, size):
        return rng.uniform(self.low, self.high, size)

    def sample_into(self, rng, out):
        # The same numbers as sample(): numpy's uniform is low + (high − low)·U.
        rng.random(out=out)
        out *= self.high - self.low
        out += self.low


@dataclass(frozen=True)
class Triangular(Distribution):
    """Triangular on [low, high] with peak at ``mode`` (symmetric when mode is the centre).

    Notes
    -----
    JCGM 101:2008, 6.4.5 (symmetric); for the asymmetric form
    E = (low + mode + high)/3 and
    V = (low² + mode² + high² − low·mode − low·high − mode·high)/18.
    """

    low: float
    mode: float
    high: float

    def __post_init__(self):
        lo, hi = _limits(self.low, self.high)
        mode = _finite("mode", self.mode)
        if not lo <= mode <= hi:
            raise ValueError(f"mode ({mode}) must lie in [low, high] = [{lo}, {hi}]")
        object.__setattr__(self, "low", lo)
        object.__setattr__(self, "mode", mode)
        object.__setattr__(self, "high", hi)

    @property
    def mean(self) -> float:
        return (self.low + self.mode + self.high) / 3.0

    @property
    def standard_uncertainty(self) -> float:
        a, c, b = self.low, self.mode, self.high
        return math.sqrt(max(a * a + b * b + c * c - a * b - a * c - b * c, 0.0) / 18.0)

    def sample(self, rng, size):
        if self.high == self.low:
            return np.full(size, self.low)
        return rng.triangular(self.low, self.mode, self.high, size)


@dataclass(frozen=True)
class Trapezoidal(_SymmetricInterval):
    """Symmetric trapezoid on [low, high]; ``beta`` is top width / base width (JCGM 101, 6.4.4).

    Notes
    -----
    E = (low + high)/2, V = (high − low)²(1 + β²)/24 (JCGM 101:2008, 6.4.4.3);
    sampled as low + (high − low)/2 · [(1 + β) r₁ + (1 − β) r₂] (6.4.4.4).
    β = 0 is triangular, β = 1 rectangular.
    """

    beta: float

    def __post_init__(self):
        super().__post_init__()
        beta = _finite("beta", self.beta)
        if not 0.0 <= beta <= 1.0:
            raise ValueError(f"beta must lie in [0, 1], got {beta}")
        object.__setattr__(self, "beta", beta)

    @property
    def standard_uncertainty(self) -> float:
        return (self.high - self.low) * math.sqrt((1.0 + self.beta**2) / 24.0)

    def sample(self, rng, size):
        r1, r2 = rng.random(size), rng.random(size)
        w = 0.5 * (self.high - self.low)
        return self.low + w * ((1.0 + self.beta) * r1 + (1.0 - self.beta) * r2)


@dataclass(frozen=True)
class CurvilinearTrapezoid(_SymmetricInterval):
    """Rectangular with inexactly known limits low ± d, high ± d (JCGM 101:2008, 6.4.3).

    Notes
    -----
    E = (low + high)/2, V = (high − low)²/12 + d²/9 (6.4.3.3).  Sampled as
    a_s = (low − d) + 2d r₁, b_s = (low + high) − a_s, ξ = a_s + (b_s − a_s) r₂
    (6.4.3.4).  Requires d <= (high − low)/2.
    """

    d: float

    def __post_init__(self):
        super().__post_init__()
        lo, hi = self.low, self.high
        d = _nonnegative("d", self.d)
        if d > 0.5 * (hi - lo):
            raise ValueError(
                f"d ({d}) must not exceed the half-width (high - low)/2 = {0.5 * (hi - lo)}"
            )
        object.__setattr__(self, "d", d)

    @property
    def standard_uncertainty(self) -> float:
        return math.sqrt((self.high - self.low) ** 2 / 12.0 + self.d**2 / 9.0)

    def sample(self, rng, size):
        r1, r2 = rng.random(size), rng.random(size)
        a_s = (self.low - self.d) + 2.0 * self.d * r1
        b_s = (self.low + self.high) - a_s
        return a_s + (b_s - a_s) * r2


@dataclass(frozen=True)
class Arcsine(_SymmetricInterval):
    """Arcsine (U-shaped) on [low, high] (JCGM 101:2008, 6.4.6).

    Notes
    -----
    E = (low + high)/2, u = (high − low)/√8 = a/√2; sampled as
    (low + high)/2 + (high − low)/2 · sin(2π r) (6.4.6.4).
    """

    @property
    def standard_uncertainty(self) -> float:
        return (self.high - self.low) / math.sqrt(8.0)

    def sample(self, rng, size):
        return self.mean + 0.5 * (self.high - self.low) * np.sin(2.0 * np.pi * rng.random(size))


@dataclass(frozen=True)
class Beta(Distribution):
    """Beta distribution with shape parameters ``alpha``, ``beta`` on [low, high].

    Parameters
    ----------
    low, high : float
        Limits of the support (high > low).
    alpha, beta : float
        Shape parameters, > 0 (alpha = beta: symmetric about the centre; alpha = beta = 1:
        rectangular).

    Notes
    -----
    With ``w = high − low`` and ``s = alpha + beta``::

        E = low + w·alpha/s,     V = w²·alpha·beta / (s²·(s + 1)).

    The random part of a geometric error (Aguado et al. (2019), eqs 18–20) is modelled by
    a normal or a beta distribution (Ahn and Cho (2000), cited there).

    References
    ----------
    N. L. Johnson, S. Kotz, N. Balakrishnan, *Continuous Univariate Distributions*, vol. 2,
    2nd ed., Wiley, 1995, ch. 25.
    """

    low: float
    high: float
    alpha: float
    beta: float

    def __post_init__(self):
        lo, hi = _limits(self.low, self.high)
        if hi == lo:
            raise ValueError(f"high ({hi}) must be > low ({lo}) for a beta distribution")
        for name in ("alpha", "beta"):
            if _finite(name, getattr(self, name)) <= 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        object.__setattr__(self, "low", lo)
        object.__setattr__(self, "high", hi)
        object.__setattr__(self, "alpha", float(self.alpha))
        object.__setattr__(self, "beta", float(self.beta))

    @property
    def mean(self) -> float:
        return self.low + (self.high - self.low) * self.alpha / (self.alpha + self.beta)

    @property
    def standard_uncertainty(self) -> float:
        s = self.alpha + self.beta
        return (self.high - self.low) * math.sqrt(self.alpha * self.beta / (s * s * (s + 1.0)))

    def sample(self, rng, size):
        return self.low + (self.high - self.low) * rng.beta(self.alpha, self.beta, size)


@dataclass(frozen=True)
class StudentT(Distribution):
    """Scaled and shifted t distribution t_ν(x, s²) (JCGM 101:2008, 6.4.9).

    Parameters
    ----------
    x : float
        Location (for n indications: their mean).
    s : float
        Scale, >= 0 (for n indications: s/√n).
    dof : float
        Degrees of freedom ν > 0 (for n indications: n − 1).

    Notes
    -----
    E = x for ν > 1; V = ν/(ν − 2)·s² for ν > 2 (6.4.9.3).  For ν <= 2 the
    variance does not exist and ``standard_uncertainty`` is ``inf``: such an
    input can be propagated by Monte Carlo but not by the GUF.
    """

    x: float
    s: float
    dof: float

    def __post_init__(self):
        object.__setattr__(self, "x", _finite("x", self.x))
        object.__setattr__(self, "s", _nonnegative("s", self.s))
        dof = _finite("dof", self.dof)
        if dof <= 0:
            raise ValueError(f"dof must be > 0, got {dof}")
        object.__setattr__(self, "dof", dof)

    @property
    def mean(self) -> float:
        return self.x

    @property
    def standard_uncertainty(self) -> float:
        if self.dof <= 2:
            return math.inf
        return self.s * math.sqrt(self.dof / (self.dof - 2.0))

    def sample(self, rng, size):
        return self.x + self.s * rng.standard_t(self.dof, size)

    def sample_into(self, rng, out):
        np.multiply(rng.standard_t(self.dof, out.shape[0]), self.s, out=out)
        out += self.x


@dataclass(frozen=True)
class Samples(Distribution):
    """The empirical distribution of user-supplied samples, resampled with replacement.

    Notes
    -----
    The empirical distribution puts mass 1/K on each of the K values, so its
    variance is the divisor-K variance; that is what resampling reproduces.
    """

    values: np.ndarray = field(repr=False)

    def __post_init__(self):
        v = np.asarray(self.values, dtype=float).ravel()
        if v.size == 0:
            raise ValueError("values must not be empty")
        if not np.all(np.isfinite(v)):
            raise ValueError(f"values contains {np.count_nonzero(~np.isfinite(v))} NaN/inf")
        v.setflags(write=False)
        object.__setattr__(self, "values", v)

    @property
    def mean(self) -> float:
        return float(self.values.mean())

    @property
    def standard_uncertainty(self) -> float:
        return float(self.values.std())

    def sample(self, rng, size):
        return self.values[rng.integers(0, self.values.size, size)]


def psd_factor(covariance, name: str = "covariance", rtol: float = 1e-9) -> np.ndarray:
    """A factor S (N, r) with S Sᵀ = covariance, for a positive semidefinite matrix.

    Parameters
    ----------
    covariance : (N, N) array_like
        Symmetric positive semidefinite matrix; may be singular.
    name : str
        Parameter name used in error messages.
    rtol : float
        Eigenvalues down to ``-rtol * max(eigenvalue)`` are rounding noise and
        set to zero; anything more negative is an error.

    Returns
    -------
    (N, r) ndarray
        S = V_r diag(sqrt(λ_r)) from the symmetric eigendecomposition restricted
        to the r positive eigenvalues.  Rows with zero variance are exactly zero,
        so those components are sampled as constants.

    Raises
    ------
    ValueError
        If the matrix is not square, not finite, not symmetric, has a negative
        variance, or is not PSD beyond ``rtol``.

    Notes
    -----
    A Cholesky factor (JCGM 101:2008, 6.4.8.4) fails for singular covariances,
    e.g. zero-variance axes or a sample covariance of K replicates (rank K − 1);
    the eigen factor does not (a sample covariance of K < N replicates is singular, as in Sepahi
    Boroujeni 2021, Ch. 5).
    """
    c = np.asarray(covariance, dtype=float)
    if c.ndim != 2 or c.shape[0] != c.shape[1]:
        raise ValueError(f"{name} must be a square matrix, got shape {c.shape}")
    if not np.all(np.isfinite(c)):
        raise ValueError(f"{name} contains NaN or inf")
    scale = max(float(np.max(np.abs(c))), np.finfo(float).tiny) if c.size else 1.0
    if not np.allclose(c, c.T, rtol=0.0, atol=1e-12 * scale):
        raise ValueError(f"{name} must be symmetric")
    diag = np.diag(c)
    if np.any(diag < 0):
        raise ValueError(f"{name} has a negative variance at index {int(np.argmin(diag))}")
    n = c.shape[0]
    factor = np.zeros((n, 0))
    live = np.flatnonzero(diag > 0)
    dead = np.flatnonzero(diag == 0)
    if dead.size and np.any(c[np.ix_(dead, np.arange(n))] != 0):
        raise ValueError(
            f"{name} is not positive semidefinite: a zero-variance row has a non-zero covariance"
        )
    if live.size:
        sub = 0.5 * (c[np.ix_(live, live)] + c[np.ix_(live, live)].T)
        w, v = np.linalg.eigh(sub)  # ascending eigenvalues
        tol = rtol * max(float(w[-1]), 0.0)
        if w[0] < -tol:
            raise ValueError(
                f"{name} is not positive semidefinite: smallest eigenvalue {w[0]:.3g} "
                f"(tolerance {-tol:.3g})"
            )
        keep = w > tol
        factor = np.zeros((n, int(keep.sum())))
        factor[live] = v[:, keep] * np.sqrt(w[keep])
    return factor


class _VectorDistribution(Distribution):
    """A distribution of a vector quantity; samples have shape (size, N)."""

    multivariate = True

    @property
    def dimension(self) -> int:
        return self.mean_vector.size

    @property
    def mean(self) -> np.ndarray:
        return self.mean_vector


@dataclass(frozen=True)
class MultivariateNormal(_VectorDistribution):
    """Multivariate Gaussian N(mean, covariance), also for singular PSD covariances.

    Notes
    -----
    Samples are mean + S z with S from :func:`psd_factor` (JCGM 101:2008, 6.4.8
    uses a Cholesky factor; the eigen factor also covers rank-deficient cases).
    """

    mean_vector: np.ndarray = field(repr=False)
    covariance: np.ndarray = field(repr=False)
    _factor: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        mu = np.array(self.mean_vector, dtype=float).ravel()
        if not np.all(np.isfinite(mu)):
            raise ValueError("mean contains NaN or inf")
        cov = np.array(self.covariance, dtype=float)
        if cov.shape != (mu.size, mu.size):
            raise ValueError(f"covariance must have shape {(mu.size, mu.size)}, got {cov.shape}")
        factor = psd_factor(cov, "covariance")
        for a in (mu, cov, factor):
            a.setflags(write=False)
        object.__setattr__(self, "mean_vector", mu)
        object.__setattr__(self, "covariance", cov)
        object.__setattr__(self, "_factor", factor)

    @classmethod
    def from_replicates(cls, samples) -> MultivariateNormal:
        """The normal with the mean and sample covariance of K replicates (K, N).

        Draws are x̄ + Σ_k z_k (x_k − x̄)/√(K − 1) with z ~ N(0, I_K), whose
        covariance is exactly the sample covariance (rank <= K − 1; Sepahi Boroujeni 2021, Ch. 5).
        """
        x = np.asarray(samples, dtype=float)
        if x.ndim != 2 or x.shape[0] < 2:
            raise ValueError(f"samples must have shape (K >= 2, N), got {x.shape}")
        if not np.all(np.isfinite(x)):
            raise ValueError("samples contains NaN or inf")
        mu = x.mean(axis=0)
        dev = (x - mu) / math.sqrt(x.shape[0] - 1)  # (K, N)
        obj = cls.__new__(cls)
        cov = dev.T @ dev
        factor = np.ascontiguousarray(dev.T)  # (N, K)
        for a in (mu, cov, factor):
            a.setflags(write=False)
        object.__setattr__(obj, "mean_vector", mu)
        object.__setattr__(obj, "covariance", cov)
        object.__setattr__(obj, "_factor", factor)
        return obj

    @property
    def standard_uncertainty(self) -> np.ndarray:
        return np.sqrt(np.diag(self.covariance))

    def sample(self, rng, size):
        shape = (size,) if isinstance(size, int) else tuple(size)
        z = rng.standard_normal((*shape, self._factor.shape[1]))  # (..., r)
        return self.mean_vector + z @ self._factor.T  # (..., N)

    def sample_transposed(self, rng, size: int) -> np.ndarray:
        """``sample(rng, size).T`` from the same draws, computed as (N, size) C-ordered.

        For writing into the rows of a column-major (size, N) array: a fancy-indexed write
        of the (size, N) block into it costs about three times the draws themselves.
        """
        z = rng.standard_normal((size, self._factor.shape[1]))  # the stream of ``sample``
        out = self._factor @ z.T  # (N, size)
        out += self.mean_vector[:, None]
        return out


@dataclass(frozen=True)
class MultivariateT(_VectorDistribution):
    """Multivariate t_ν(mean, scale) (JCGM 102:2011, 5.3.2; JCGM 101:2008, 6.4.9).

    Notes
    -----
    X = mean + S z · sqrt(ν/χ²_ν) with S Sᵀ = scale; covariance ν/(ν − 2)·scale
    for ν > 2 (infinite otherwise).
    """

    mean_vector: np.ndarray = field(repr=False)
    scale: np.ndarray = field(repr=False)
    dof: float = math.inf
    _factor: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        mu = np.array(self.mean_vector, dtype=float).ravel()
        if not np.all(np.isfinite(mu)):
            raise ValueError("mean contains NaN or inf")
        scale = np.array(self.scale, dtype=float)
        if scale.shape != (mu.size, mu.size):
            raise ValueError(f"scale must have shape {(mu.size, mu.size)}, got {scale.shape}")
        dof = float(self.dof)
        if math.isnan(dof) or dof <= 0:
            raise ValueError(f"dof must be > 0, got {dof}")
        factor = psd_factor(scale, "scale")
        for a in (mu, scale, factor):
            a.setflags(write=False)
        object.__setattr__(self, "mean_vector", mu)
        object.__setattr__(self, "scale", scale)
        object.__setattr__(self, "dof", dof)
        object.__setattr__(self, "_factor", factor)

    @property
    def covariance(self) -> np.ndarray:
        if self.dof <= 2:
            return np.full(self.scale.shape, np.inf)
        if math.isinf(self.dof):
            return self.scale.copy()
        return self.dof / (self.dof - 2.0) * self.scale

    @property
    def standard_uncertainty(self) -> np.ndarray:
        return np.sqrt(np.diag(self.covariance))

    def sample(self, rng, size):
        shape = (size,) if isinstance(size, int) else tuple(size)
        z = rng.standard_normal((*shape, self._factor.shape[1])) @ self._factor.T  # (..., N)
        if math.isinf(self.dof):
            return self.mean_vector + z
        w = np.sqrt(self.dof / rng.chisquare(self.dof, shape))  # (...,)
        return self.mean_vector + z * w[..., None]


# --------------------------------------------------------------------------- registry


def _bounded(kind: str, params: dict, extra: tuple[str, ...] = ()) -> tuple[float, float]:
    """Limits from either (low, high) or (x, a) = centre and half-width."""
    if {"low", "high"} <= params.keys() and not ({"x", "a"} & params.keys()):
        return _limits(params.pop("low"), params.pop("high"))
    if {"x", "a"} <= params.keys() and not ({"low", "high"} & params.keys()):
        x, a = _finite("x", params.pop("x")), _nonnegative("a", params.pop("a"))
        return x - a, x + a
    forms = " or ".join(f"({', '.join((*f, *extra))})" for f in (("low", "high"), ("x", "a")))
    raise ValueError(f"distribution {kind!r} takes parameters {forms}; got {sorted(params)}")


def _normal(p: dict) -> Normal:
    if "u" in p or "U" not in p:
        return Normal(p.pop("x"), p.pop("u"))
    # Certificate form: expanded uncertainty U with coverage factor k.
    U, k = _nonnegative("U", p.pop("U")), _finite("k", p.pop("k"))
    if k <= 0:
        raise ValueError(f"k must be > 0, got {k}")
    return Normal(p.pop("x"), U / k)


def _triangular(p: dict) -> Triangular:
    if "mode" in p:
        return Triangular(p.pop("low"), p.pop("mode"), p.pop("high"))
    lo, hi = _bounded("triangular", p)
    return Triangular(lo, 0.5 * (lo + hi), hi)


def _trapezoidal(p: dict) -> Trapezoidal:
    lo, hi = _bounded("trapezoidal", p, ("beta",))
    return Trapezoidal(lo, hi, p.pop("beta"))


def _beta(p: dict) -> Beta:
    lo, hi = _bounded("beta", p, ("alpha", "beta"))
    return Beta(lo, hi, p.pop("alpha"), p.pop("beta"))


def _curvilinear(p: dict) -> CurvilinearTrapezoid:
    lo, hi = _bounded("curvilinear-trapezoid", p, ("d",))
    return CurvilinearTrapezoid(lo, hi, p.pop("d"))


_REGISTRY: dict[str, tuple[Callable[[dict], Distribution], str]] = {
    "normal": (_normal, "x, u  or  x, U, k"),
    "rectangular": (lambda p: Rectangular(*_bounded("rectangular", p)), "low, high  or  x, a"),
    "triangular": (_triangular, "low, mode, high  or  low, high  or  x, a"),
    "trapezoidal": (_trapezoidal, "low, high, beta  or  x, a, beta"),
    "curvilinear-trapezoid": (_curvilinear, "low, high, d  or  x, a, d"),
    "arcsine": (lambda p: Arcsine(*_bounded("arcsine", p)), "low, high  or  x, a"),
    "beta": (_beta, "low, high, alpha, beta  or  x, a, alpha, beta"),
    "student-t": (lambda p: StudentT(p.pop("x"), p.pop("s"), p.pop("dof")), "x, s, dof"),
    "samples": (lambda p: Samples(p.pop("values")), "values"),
    "multivariate-normal": (
        lambda p: MultivariateNormal(p.pop("mean"), p.pop("covariance")),
        "mean, covariance",
    ),
    "multivariate-t": (
        lambda p: MultivariateT(p.pop("mean"), p.pop("scale"), p.pop("dof")),
        "mean, scale, dof",
    ),
}

#: Names accepted by :func:`make_distribution`.
DISTRIBUTION_KINDS: tuple[str, ...] = tuple(_REGISTRY)


def make_distribution(kind: str, **params) -> Distribution:
    """Create a distribution from its name and parameters (used by model files).

    Parameters
    ----------
    kind : str
        One of :data:`DISTRIBUTION_KINDS` (case and ``_``/``-`` insensitive).
    **params
        The parameters of that kind, e.g. ``x=0, a=0.5`` for ``"rectangular"``.

    Returns
    -------
    Distribution

    Raises
    ------
    ValueError
        Unknown kind (the message lists the known kinds), a missing or
        unexpected parameter, or an invalid value (the message names it).

    Examples
    --------
    >>> round(make_distribution("rectangular", x=10.0, a=0.5).standard_uncertainty, 6)
    0.288675
    """
    key = str(kind).strip().lower().replace("_", "-")
    if key not in _REGISTRY:
        raise ValueError(f"unknown distribution {kind!r}; known kinds: {', '.join(_REGISTRY)}")
    builder, signature = _REGISTRY[key]
    remaining = dict(params)
    try:
        dist = builder(remaining)
    except KeyError as exc:
        raise ValueError(
            f"distribution {key!r} is missing parameter {exc.args[0]!r}; it takes {signature}"
        ) from None
    if remaining:
        raise ValueError(
            f"distribution {key!r} got unexpected parameter(s) {sorted(remaining)}; "
            f"it takes {signature}"
        )
    return dist
