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

Correlated inputs with finite degrees of freedom
------------------------------------------------
Welch–Satterthwaite (JCGM 100:2008, G.4.1) assumes independent inputs.  Inputs estimated
together from the same n sets of simultaneous observations (JCGM 100:2008, 5.2.3 and H.2)
are correlated *and* carry ν = n − 1; declare them an *ensemble* (``ensembles=`` or
:meth:`InputSet.from_observations`) and the GUF treats the ensemble as one component of
ν = n − 1 (Willink 2007, section 4.1.1; GTC's ``real_ensemble``).

Units are labels: they are checked with :func:`mtmetrology.units.parse_unit` so a
typo is caught, but values are used in the units the user declares.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mtmetrology.errors import InputError
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
    ensembles : sequence of sequences of str, optional
        Groups of input names estimated together from the same observations (JCGM
        100:2008, 5.2.3): their members may be correlated while having finite degrees
        of freedom, which must be equal within a group.

    Raises
    ------
    ValueError
        Duplicate names, a malformed or non-PSD correlation matrix, or a
        correlation involving a non-normal input.
    InputError
        An ensemble naming an unknown input, an input in two ensembles, or members
        with different or infinite degrees of freedom.

    References
    ----------
    Willink, R. (2007). A generalization of the Welch–Satterthwaite formula for use with
    correlated uncertainty components. *Metrologia* 44(5), 340–349.
    """

    def __init__(
        self,
        quantities: Sequence[InputQuantity],
        correlation=None,
        ensembles: Sequence[Sequence[str]] = (),
    ):
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
        self._ensemble = self._check_ensembles(ensembles, quantities)
        self._build_sampler()

    @classmethod
    def from_covariance(
        cls, names, estimate, covariance, units=None, dof=None, ensembles=()
    ) -> InputSet:
        """Normal inputs with a joint (possibly singular) covariance.

        Parameters
        ----------
        names : sequence of str, length N
        estimate : (N,) array_like
        covariance : (N, N) array_like
            Positive semidefinite; zero-variance inputs are constants.
        units : sequence of str, optional
        dof : sequence of float or None, optional
        ensembles : sequence of sequences of str, optional
            See :class:`InputSet`.
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
        return cls(qs, correlation=r, ensembles=ensembles)

    @classmethod
    def from_observations(cls, names, observations, units=None) -> InputSet:
        """Type A inputs from n simultaneous observations of N quantities, as one ensemble.

        Parameters
        ----------
        names : sequence of str, length N
        observations : (n, N) array_like
            Row k holds the k-th set of simultaneous indications, n >= 2.
        units : sequence of str, optional

        Returns
        -------
        InputSet
            Normal inputs with estimates the arithmetic means (JCGM 100:2008, 4.2.1),
            covariance of the means s(q̄_i, q̄_j) = Σ_k (q_ik − q̄_i)(q_jk − q̄_j) / (n(n − 1))
            (5.2.3, eq. 17), ν = n − 1 each, declared one ensemble.

        Raises
        ------
        InputError
            Fewer than two observations, a shape that disagrees with ``names``, or a
            non-finite value.

        Examples
        --------
        GUM H.2: five simultaneous observations of V, I and φ give r(V, I) = −0.36.

        >>> obs = [[5.007, 19.663e-3, 1.0456], [4.994, 19.639e-3, 1.0438],
        ...        [5.005, 19.640e-3, 1.0468], [4.990, 19.685e-3, 1.0428],
        ...        [4.999, 19.678e-3, 1.0433]]
        >>> s = InputSet.from_observations(["V", "I", "phi"], obs, ["", "", "rad"])
        >>> round(float(s.correlation[0, 1]), 2), s.dof.tolist()
        (-0.36, [4.0, 4.0, 4.0])
        """
        q = np.asarray(observations, dtype=float)
        names = list(names)
        if q.ndim != 2 or q.shape[1] != len(names) or q.shape[0] < 2:
            raise InputError(
                f"observations must have shape (n >= 2, {len(names)}) for inputs {names}, "
                f"got {q.shape}"
            )
        if not np.all(np.isfinite(q)):
            raise InputError("observations contain NaN or inf; remove or repair those rows")
        n = q.shape[0]
        covariance = np.cov(q, rowvar=False, ddof=1).reshape(len(names), len(names)) / n
        return cls.from_covariance(
            names, q.mean(axis=0), covariance, units, dof=[n - 1] * len(names), ensembles=[names]
        )

    @staticmethod
    def _check_ensembles(ensembles, quantities) -> np.ndarray:
        """(N,) ensemble number of each input, −1 outside any ensemble."""
        names = [q.name for q in quantities]
        index = np.full(len(names), -1)
        for number, group in enumerate(ensembles):
            group = list(group)
            unknown = [name for name in group if name not in names]
            if unknown:
                raise InputError(f"ensemble {group}: unknown inputs {unknown}; inputs are {names}")
            members = [names.index(name) for name in group]
            taken = [names[i] for i in members if index[i] >= 0]
            if taken:
                raise InputError(f"inputs {taken} are in more than one ensemble")
            dof = {quantities[i].effective_dof for i in members}
            if len(dof) != 1 or math.isinf(next(iter(dof))):
                raise InputError(
                    f"ensemble {group}: members must share one finite number of degrees of "
                    f"freedom (Willink 2007, 4.1.1), got {sorted(dof)}"
                )
            index[members] = number
        return index

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
        # Runs of consecutive independent normals draw in one call: filling the rows
        # a..b of the (N, size) transposed output in order takes the same numbers from
        # the stream as one call per input, so the draws are bit-identical.
        self._sampling_steps: list = []
        for i in self._single_index:
            dist = self._quantities[i].distribution
            if type(dist) is not Normal:
                self._sampling_steps.append(int(i))
                continue
            last = self._sampling_steps[-1] if self._sampling_steps else None
            if isinstance(last, list) and last[1] == i:
                last[1] += 1
            else:
                self._sampling_steps.append([int(i), int(i) + 1])
        self._sampling_steps = [
            step
            if isinstance(step, int)
            else (
                step[0],
                step[1],
                np.array([[self._quantities[k].distribution.x] for k in range(*step)]),
                np.array([[self._quantities[k].distribution.u] for k in range(*step)]),
            )
            for step in self._sampling_steps
        ]

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
    def standard_uncertainty(self) -> np.ndarray:
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
    def ensemble(self) -> np.ndarray:
        """(N,) ensemble number of each input (−1: in no ensemble)."""
        return self._ensemble.copy()

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
        # Column-major, so each input's draws are written to contiguous memory.
        out = np.empty((len(self._quantities), size)).T
        for step in self._sampling_steps:
            if isinstance(step, int):
                self._quantities[step].distribution.sample_into(rng, out[:, step])
                continue
            first, stop, x, u = step
            block = out.T[first:stop]  # (stop - first, size), C-contiguous
            rng.standard_normal(out=block)
            block *= u
            block += x
        if self._joint is not None:
            # Whole contiguous columns of ``out``: see MultivariateNormal.sample_transposed.
            out.T[self._joint_index] = self._joint.sample_transposed(rng, size)
        return out

    def __repr__(self) -> str:
        return f"InputSet({self.names})"
