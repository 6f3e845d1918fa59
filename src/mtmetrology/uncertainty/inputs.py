"""Input quantities of a measurement model: distributions, units, correlations.

An :class:`InputSet` is what GUF and Monte Carlo both consume: estimates,
covariance and degrees of freedom for the GUF, ``sample(rng, size)`` for the MCM.

Correlated inputs
-----------------
Correlations are allowed between *normal* inputs only; those inputs are sampled
jointly from one multivariate normal (JCGM 101:2008, 6.4.8), which reproduces the
stated covariance exactly.  A correlation involving a non-normal input is refused
with an error: a Gaussian copula would keep the marginals but not the stated
correlation coefficient (the Pearson correlation of the transformed marginals
differs from the copula parameter), so the GUF and the MCM would propagate
different covariances.  Describe such inputs by their joint samples
(:meth:`InputSet.from_covariance` for normal vectors) instead.

Units are labels: they are checked with :func:`mtmetrology.units.parse_unit` so a
typo is caught, but values are used in the units the user declares.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mtmetrology.rng import SeedLike, as_generator
from mtmetrology.uncertainty.distributions import (
    Distribution,
    MultivariateNormal,
    Normal,
    StudentT,
    psd_factor,
)
from mtmetrology.units import UnitError, parse_unit

__all__ = ["InputQuantity", "InputSet"]


@dataclass(frozen=True)
class InputQuantity:
    """One scalar input quantity X_i.

    Parameters
    ----------
    name : str
        Identifier used in budgets and model expressions.
    distribution : Distribution
        A univariate distribution (state of knowledge about X_i).
    unit : str
        Unit label, checked by :func:`mtmetrology.units.parse_unit`.
    dof : float or None
        Degrees of freedom of u(x_i) for Welch–Satterthwaite; ``None`` means
        infinite, except for a :class:`StudentT`, whose ν is used.
    """

    name: str
    distribution: Distribution
    unit: str = ""
    dof: float | None = None

    def __post_init__(self):
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"input name must be a non-empty string, got {self.name!r}")
        if not isinstance(self.distribution, Distribution) or self.distribution.multivariate:
            raise ValueError(
                f"input {self.name!r}: distribution must be a univariate Distribution, "
                f"got {type(self.distribution).__name__}"
            )
        try:
            parse_unit(self.unit)
        except UnitError as exc:
            raise ValueError(f"input {self.name!r}: {exc}") from None
        if self.dof is not None:
            dof = float(self.dof)
            if math.isnan(dof) or dof <= 0:
                raise ValueError(f"input {self.name!r}: dof must be > 0, got {self.dof}")
            object.__setattr__(self, "dof", dof)

    @property
    def effective_dof(self) -> float:
        """ν_i for Welch–Satterthwaite (inf when unknown)."""
        if self.dof is not None:
            return self.dof
        if isinstance(self.distribution, StudentT):
            return self.distribution.dof
        return math.inf


class InputSet:
    """The N input quantities of a model with their (optional) correlation matrix.

    Parameters
    ----------
    quantities : sequence of InputQuantity
        Unique names.
    correlation : (N, N) array_like, optional
        Correlation coefficients; symmetric, unit diagonal, entries in [−1, 1],
        positive semidefinite.  Non-zero off-diagonal entries are allowed only
        between :class:`Normal` inputs (see the module notes).

    Raises
    ------
    ValueError
        Duplicate names, a malformed or non-PSD correlation matrix, or a
        correlation involving a non-normal input.
    """

    def __init__(self, quantities: Sequence[InputQuantity], correlation=None):
        quantities = tuple(quantities)
        if not quantities:
            raise ValueError("an InputSet needs at least one input quantity")
        names = [q.name for q in quantities]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"duplicate input names: {dup}")
        n = len(quantities)
        self._quantities = quantities
        u = np.array([q.distribution.standard_uncertainty for q in quantities], dtype=float)
        if correlation is None:
            r = np.eye(n)
        else:
            r = self._check_correlation(np.array(correlation, dtype=float), quantities)
        self._correlation = r
        finite_u = np.where(np.isfinite(u), u, 0.0)
        # Covariance U_x = D R D; inputs with infinite variance keep inf on the diagonal.
        cov = r * np.outer(finite_u, finite_u)
        cov[np.diag_indices(n)] = u**2
        self._covariance = cov
        self._build_sampler()

    @classmethod
    def from_covariance(cls, names, estimate, covariance, units=None, dof=None) -> InputSet:
        """Normal inputs with a joint (possibly singular) covariance.

        Parameters
        ----------
        names : sequence of str, length N
        estimate : (N,) array_like
        covariance : (N, N) array_like
            Positive semidefinite; zero-variance inputs are constants.
        units : sequence of str, optional
        dof : sequence of float or None, optional
        """
        x = np.asarray(estimate, dtype=float).ravel()
        cov = np.asarray(covariance, dtype=float)
        n = x.size
        if len(names) != n or cov.shape != (n, n):
            raise ValueError(
                f"names ({len(names)}), estimate ({n}) and covariance {cov.shape} must agree"
            )
        psd_factor(cov, "covariance")
        u = np.sqrt(np.diag(cov))
        units = [""] * n if units is None else list(units)
        dof = [None] * n if dof is None else list(dof)
        qs = [
            InputQuantity(nm, Normal(xi, ui), un, df)
            for nm, xi, ui, un, df in zip(names, x, u, units, dof, strict=True)
        ]
        live = u > 0
        r = np.eye(n)
        r[np.ix_(live, live)] = cov[np.ix_(live, live)] / np.outer(u[live], u[live])
        np.fill_diagonal(r, 1.0)
        return cls(qs, correlation=r)

    @staticmethod
    def _check_correlation(r: np.ndarray, quantities) -> np.ndarray:
        n = len(quantities)
        if r.shape != (n, n):
            raise ValueError(f"correlation must have shape {(n, n)}, got {r.shape}")
        if not np.all(np.isfinite(r)):
            raise ValueError("correlation contains NaN or inf")
        if not np.allclose(np.diag(r), 1.0):
            raise ValueError("correlation must have a unit diagonal")
        if not np.allclose(r, r.T, atol=1e-12):
            raise ValueError("correlation must be symmetric")
        if np.any(np.abs(r) > 1.0 + 1e-12):
            raise ValueError("correlation coefficients must lie in [-1, 1]")
        psd_factor(r, "correlation")
        for i, j in zip(*np.nonzero(np.triu(r, 1)), strict=True):
            for k in (i, j):
                if not isinstance(quantities[k].distribution, Normal):
                    raise ValueError(
                        f"inputs {quantities[i].name!r} and {quantities[j].name!r} are "
                        f"correlated but {quantities[k].name!r} is "
                        f"{type(quantities[k].distribution).__name__}; correlations are "
                        "supported between normal inputs only (sampled jointly as a "
                        "multivariate normal)"
                    )
        return r

    def _build_sampler(self) -> None:
        """Group correlated normals into one multivariate normal; the rest sample alone."""
        off = np.triu(self._correlation, 1) != 0
        joint = np.flatnonzero(off.any(axis=0) | off.any(axis=1))
        self._joint_index = joint
        self._joint = (
            MultivariateNormal(self.estimate[joint], self._covariance[np.ix_(joint, joint)])
            if joint.size
            else None
        )
        self._single_index = np.setdiff1d(np.arange(len(self._quantities)), joint)

    # ------------------------------------------------------------------ properties
    @property
    def quantities(self) -> tuple[InputQuantity, ...]:
        return self._quantities

    def __len__(self) -> int:
        return len(self._quantities)

    @property
    def names(self) -> list[str]:
        return [q.name for q in self._quantities]

    @property
    def units(self) -> list[str]:
        return [q.unit for q in self._quantities]

    @property
    def estimate(self) -> np.ndarray:
        """(N,) expectations of the inputs."""
        return np.array([q.distribution.mean for q in self._quantities], dtype=float)

    @property
    def standard_uncertainties(self) -> np.ndarray:
        """(N,) u(x_i) (inf for a t input with ν <= 2)."""
        return np.sqrt(np.diag(self._covariance))

    @property
    def covariance(self) -> np.ndarray:
        """(N, N) U_x."""
        return self._covariance.copy()

    @property
    def correlation(self) -> np.ndarray:
        """(N, N) correlation matrix as given (identity when none)."""
        return self._correlation.copy()

    @property
    def dof(self) -> np.ndarray:
        """(N,) degrees of freedom ν_i (inf when not given)."""
        return np.array([q.effective_dof for q in self._quantities], dtype=float)

    def sample(self, rng: SeedLike, size: int) -> np.ndarray:
        """Draw ``size`` joint realisations of the inputs.

        Parameters
        ----------
        rng : Generator, SeedSequence or int
            Source of randomness (see :func:`mtmetrology.rng.as_generator`).
        size : int
            Number of draws.

        Returns
        -------
        (size, N) ndarray
        """
        rng = as_generator(rng)
        out = np.empty((size, len(self._quantities)))
        for i in self._single_index:
            out[:, i] = self._quantities[i].distribution.sample(rng, size)
        if self._joint is not None:
            out[:, self._joint_index] = self._joint.sample(rng, size)
        return out

    def __repr__(self) -> str:
        return f"InputSet({self.names})"
