"""Probing repeatability of on-machine measurement: the pose models.

:func:`fit_repeatability_model` fits, on the per-target statistics of
:mod:`mtmetrology.omm.repeatability`, the separable polynomial models of Sepahi Boroujeni
(2021), eqs. 4-1 (standard deviations, 22 coefficients) and 4-2 (covariances, 36
coefficients), on factors normalised to [−1, 1], by the library's least-squares core; the
:class:`RepeatabilityModel` predicts a positive-semidefinite 3×3 covariance (and the 5×5
``v_i`` with zero rotary rows) for any pose and approach inside the fitted range.

Factors (:data:`~mtmetrology.omm.repeatability.FACTORS`) internally in rad and mm;
standard deviations in mm, covariances in mm².

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, ch. 4 and Appendix A.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.omm.choices import MIN_TARGETS_PER_COEFFICIENT
from mtmetrology.omm.repeatability import (
    COVARIANCE_OUTPUTS,
    FACTOR_UNITS,
    FACTORS,
    STD_OUTPUTS,
    TargetStatistics,
)
from mtmetrology.optimize import least_squares
from mtmetrology.rng import SeedLike, as_generator
from mtmetrology.units import from_internal

__all__ = [
    "COVARIANCE_DEGREES",
    "STD_DEGREES",
    "VALIDATION_WARNING",
    "OutputFit",
    "PoseRangeWarning",
    "RepeatabilityModel",
    "fit_repeatability_model",
    "separable_design",
]

#: Held-out RMS error, as a fraction of the RMS of the held-out values, above which an
#: output is flagged: the model then predicts its values no better than half their size.
VALIDATION_WARNING = 0.5
#: Polynomial degree of each factor (order of FACTORS) in eq. 4-1 (standard deviations).
STD_DEGREES = (2, 4, 3, 3, 3, 3, 3)
#: Polynomial degree of each factor in eq. 4-2 (covariances): 5 for all.
COVARIANCE_DEGREES = (5,) * 7
_RANGE_SLACK = 1e-9  # normalised units: rounding of the range limits themselves


class PoseRangeWarning(UserWarning):
    """A pose outside the range the repeatability model was fitted on."""


def separable_design(z: np.ndarray, degrees: tuple[int, ...]) -> np.ndarray:
    """Design matrix of the separable pose polynomials (eqs. 4-1, 4-2).

    Parameters
    ----------
    z : (..., 7) ndarray
        Factors normalised to [−1, 1].
    degrees : tuple of int
        Degree of each factor (:data:`STD_DEGREES` or :data:`COVARIANCE_DEGREES`).

    Returns
    -------
    (..., 1 + Σ degrees) ndarray
        Columns ``1, z_f, z_f², …, z_f^deg`` for each factor f in turn (no cross terms):
        ``y = c_0 + Σ_f Σ_{p=1}^{deg_f} c_{f,p} z_f^p``.

    References
    ----------
    Sepahi Boroujeni (2021), eqs. 4-1 and 4-2.
    """
    cols = [np.ones(z.shape[:-1])]
    for f, deg in enumerate(degrees):
        cols += [z[..., f] ** p for p in range(1, deg + 1)]
    return np.stack(cols, axis=-1)


@dataclass(frozen=True)
class OutputFit:
    """One fitted output (σ_X … cov(N,T)).

    Attributes
    ----------
    name : str
        One of :data:`STD_OUTPUTS` or :data:`COVARIANCE_OUTPUTS`.
    coefficients, standard_uncertainties : (p,) ndarray
        Coefficients on the normalised factors (mm for σ, mm² for covariances) and their
        standard uncertainties s·√diag((AᵀA)⁻¹), s² = RSS/(n − p).
    r_squared : float
        1 − RSS/TSS on the fitted targets.
    validation_max_relative_error : float or None
        max |pred − meas| / |meas| over the held-out targets (None without them).
    validation_max_abs_error : float or None
        max |pred − meas| over the held-out targets (mm or mm²).
    validation_rms_relative_error : float or None
        √(Σ(pred − meas)² / Σ meas²) over the held-out targets: the held-out RMS error
        relative to the RMS of the held-out values, defined where a covariance near zero
        makes the largest relative error meaningless.
    """

    name: str
    coefficients: np.ndarray
    standard_uncertainties: np.ndarray
    r_squared: float
    validation_max_relative_error: float | None
    validation_max_abs_error: float | None
    validation_rms_relative_error: float | None = None

    @property
    def validation_flagged(self) -> bool:
        """Whether the held-out RMS error exceeds :data:`VALIDATION_WARNING`."""
        e = self.validation_rms_relative_error
        return e is not None and e > VALIDATION_WARNING


@dataclass(frozen=True)
class RepeatabilityModel:
    """Fitted repeatability models (eqs. 4-1 and 4-2) with their range of validity.

    Attributes
    ----------
    factor_low, factor_high : (7,) ndarray
        Range of each factor (rad, mm) mapped to [−1, 1].
    fits : tuple of OutputFit
        σ_X, σ_Y, σ_Z, σ_N, σ_T, cov(X,Y), cov(X,Z), cov(Y,Z), cov(N,T).
    n_fit, n_validation : int
        Targets used for fitting and held out for validation.
    """

    factor_low: np.ndarray
    factor_high: np.ndarray
    fits: tuple[OutputFit, ...]
    n_fit: int
    n_validation: int

    def normalise(self, factors: np.ndarray, *, strict: bool = True) -> np.ndarray:
        """Map factors (..., 7) to [−1, 1]; out of range → InputError (``strict``) or warning.

        Raises
        ------
        InputError
            ``strict`` and a factor outside the fitted range (the message names it).
        """
        f = np.asarray(factors, float)
        if f.shape[-1:] != (7,) or not np.all(np.isfinite(f)):
            raise InputError(f"pose factors: expected finite (..., 7) values {FACTORS}")
        z = 2.0 * (f - self.factor_low) / (self.factor_high - self.factor_low) - 1.0
        outside = np.abs(z) > 1.0 + _RANGE_SLACK
        if np.any(outside):
            k = int(np.flatnonzero(outside.reshape(-1, 7).any(axis=0))[0])
            bad = f.reshape(-1, 7)[outside.reshape(-1, 7)[:, k], k][0]
            unit = FACTOR_UNITS[k]
            msg = (
                f"pose factor {FACTORS[k]} = {from_internal(bad, unit):g} {unit} is outside the "
                f"repeatability model's range [{from_internal(self.factor_low[k], unit):g}, "
                f"{from_internal(self.factor_high[k], unit):g}] {unit}; refit with such poses"
            )
            if strict:
                raise InputError(msg)
            warnings.warn(msg, PoseRangeWarning, stacklevel=2)
        return z

    def predict(self, factors: np.ndarray, *, strict: bool = True) -> dict[str, np.ndarray]:
        """Model values of every output at poses ``factors`` (..., 7): σ clipped at 0."""
        z = self.normalise(factors, strict=strict)
        out = {}
        for fit in self.fits:
            degrees = STD_DEGREES if fit.name in STD_OUTPUTS else COVARIANCE_DEGREES
            value = separable_design(z, degrees) @ fit.coefficients
            out[fit.name] = np.maximum(value, 0.0) if fit.name in STD_OUTPUTS else value
        return out

    def covariance(self, factors: np.ndarray, *, strict: bool = True) -> np.ndarray:
        """Positive-semidefinite 3×3 covariance of the X, Y, Z readings, mm².

        Parameters
        ----------
        factors : (..., 7) array
            Poses (φ, θ, B, C in rad; X_T, Y_T, Z_T in mm).
        strict : bool
            Refuse (True) or warn about (False) poses outside the fitted range.

        Returns
        -------
        (..., 3, 3) ndarray
            [σ_X², cov_XY, cov_XZ; ·, σ_Y², cov_YZ; ·, ·, σ_Z²] from the independent fits,
            projected on the nearest PSD matrix (negative eigenvalues set to 0): the
            separate fits do not guarantee a covariance matrix.
        """
        p = self.predict(factors, strict=strict)
        sx, sy, sz = p["sigma_X"], p["sigma_Y"], p["sigma_Z"]
        c = np.stack(
            [
                np.stack([sx**2, p["cov_XY"], p["cov_XZ"]], -1),
                np.stack([p["cov_XY"], sy**2, p["cov_YZ"]], -1),
                np.stack([p["cov_XZ"], p["cov_YZ"], sz**2], -1),
            ],
            -2,
        )
        w, v = np.linalg.eigh(c)
        return (v * np.maximum(w, 0.0)[..., None, :]) @ np.swapaxes(v, -1, -2)

    def reading_covariance(
        self, factors: np.ndarray, axis_names: tuple[str, ...], *, strict: bool = True
    ) -> np.ndarray:
        """Covariance v of the readings of a machine with any axes, mm² and rad².

        Parameters
        ----------
        factors : (..., 7) array
            Pose factors, as for :meth:`covariance`.
        axis_names : sequence of str
            The machine's axes in reading order (``Machine.axis_names``); must contain
            ``"X"``, ``"Y"`` and ``"Z"``.
        strict : bool
            Refuse (True) or warn about (False) poses outside the model's range.

        Returns
        -------
        (..., n_axes, n_axes) ndarray
            The PSD 3×3 block of :meth:`covariance` on the rows and columns of X, Y and Z,
            zero for every other axis (Sepahi Boroujeni (2021), §6.2: v_i with zero rotary
            rows).

        Raises
        ------
        InputError
            When ``axis_names`` lacks one of X, Y, Z.
        """
        names = list(axis_names)
        missing = [a for a in "XYZ" if a not in names]
        if missing:
            raise InputError(
                f"axis_names: the repeatability model needs linear axes X, Y, Z; "
                f"{', '.join(missing)} missing from {names}"
            )
        idx = np.array([names.index(a) for a in "XYZ"])
        c3 = self.covariance(factors, strict=strict)
        out = np.zeros((*c3.shape[:-2], len(names), len(names)))
        out[..., idx[:, None], idx[None, :]] = c3
        return out

    def to_dict(self) -> dict:
        """The ``repeatability-model`` JSON document (deg, mm, µm, µm²)."""
        outputs = []
        for fit in self.fits:
            unit = "µm" if fit.name in STD_OUTPUTS else "µm²"
            conv = _to_micrometres if unit == "µm" else _to_square_micrometres
            outputs.append(
                {
                    "name": fit.name,
                    "unit": unit,
                    "equation": "4-1" if unit == "µm" else "4-2",
                    "coefficients": conv(fit.coefficients).tolist(),
                    "u": conv(fit.standard_uncertainties).tolist(),
                    "r_squared": fit.r_squared,
                    "validation_max_relative_error": fit.validation_max_relative_error,
                    "validation_max_abs_error": None
                    if fit.validation_max_abs_error is None
                    else float(conv(fit.validation_max_abs_error)),
                    "validation_rms_relative_error": fit.validation_rms_relative_error,
                    "validation_flagged": fit.validation_flagged,
                }
            )
        return {
            "kind": "repeatability-model",
            "version": 1,
            "factors": [
                {
                    "name": n,
                    "unit": u,
                    "low": float(from_internal(lo, u)),
                    "high": float(from_internal(hi, u)),
                }
                for n, u, lo, hi in zip(
                    FACTORS, FACTOR_UNITS, self.factor_low, self.factor_high, strict=True
                )
            ],
            "normalisation": "z = 2 (factor - low) / (high - low) - 1",
            "n_fit": self.n_fit,
            "n_validation": self.n_validation,
            "validation_warning": VALIDATION_WARNING,
            "outputs": outputs,
        }


def _to_micrometres(x):
    return from_internal(np.asarray(x, float), "µm")


def _to_square_micrometres(x):
    return from_internal(from_internal(np.asarray(x, float), "µm"), "µm")


def _check_levels(factors: np.ndarray) -> None:
    for k, name in enumerate(FACTORS):
        need = max(STD_DEGREES[k], COVARIANCE_DEGREES[k]) + 1
        levels = np.unique(factors[:, k]).size
        if levels < need:
            raise InputError(
                f"pose factor {name} takes {levels} distinct values on the fitted targets; "
                f"the degree-{need - 1} terms of eq. 4-2 need at least {need}"
            )


def fit_repeatability_model(
    stats: TargetStatistics,
    *,
    holdout: float = 0.15,
    seed: SeedLike = 0,
    factor_ranges: tuple[np.ndarray, np.ndarray] | None = None,
    min_targets_per_coefficient: float = MIN_TARGETS_PER_COEFFICIENT,
) -> RepeatabilityModel:
    """Fit the standard-deviation (eq. 4-1) and covariance (eq. 4-2) models.

    Parameters
    ----------
    stats : TargetStatistics
        Per-target statistics (one row per pose).
    holdout : float, default 0.15
        Fraction of the targets held out (drawn at random with ``seed``) to report
        validation errors; 0 fits on all.
    seed : int or numpy.random.Generator
        For the held-out draw.
    factor_ranges : ((7,), (7,)) arrays, optional
        Low and high of each factor (rad, mm) for the normalisation; the targets' range
        by default. A pose outside it is refused (or warned about) at prediction.
    min_targets_per_coefficient : float, default 3
        Fewest fitting targets per coefficient of the largest model (36 of eq. 4-2, so
        108 fitting targets by default); 0 asks for any count above the 36 that the least
        squares needs (the held-out errors then say what the model is worth).

    Returns
    -------
    RepeatabilityModel

    Raises
    ------
    InputError
        Fewer than 37 fitting targets, or fewer than ``min_targets_per_coefficient`` per
        coefficient, a factor with too few distinct values, a target
        outside ``factor_ranges`` or a holdout outside [0, 1).

    Notes
    -----
    Separable polynomials without cross terms on z = 2(P − low)/(high − low) − 1
    (Sepahi Boroujeni (2021), eqs. 4-1 and 4-2)::

        σ   = α0 + α1 φ + β1 φ² + α2 θ + β2 θ² + γ2 θ³ + δ2 θ⁴
              + Σ_{P ∈ X_T, Y_T, Z_T, B, C} (α P + β P² + γ P³)          22 coefficients
        cov = α0 + Σ_{P ∈ all seven} (α P + β P² + γ P³ + δ P⁴ + ε P⁵)    36 coefficients

    each fitted by ordinary least squares (the library's Gauss–Newton core, one step on
    a linear model). Normalising keeps the Vandermonde columns of order one (θ⁵ in
    degrees would be 6·10¹²).

    Examples
    --------
    See ``mtm repeatability fit --help`` for the records file.
    """
    if not (0.0 <= holdout < 1.0):
        raise InputError(f"holdout: must be in [0, 1), got {holdout}")
    n = len(stats)
    n_val = round(holdout * n)
    p_max = separable_design(np.zeros((1, 7)), COVARIANCE_DEGREES).shape[1]
    if n - n_val <= p_max:
        raise InputError(
            f"{n} targets ({n_val} held out): the covariance model (eq. 4-2) needs more than "
            f"{p_max} fitting targets; probe more poses or lower the holdout"
        )
    if n - n_val < min_targets_per_coefficient * p_max:
        raise InputError(
            f"{n} targets ({n_val} held out): {n - n_val} fitting targets for the {p_max} "
            f"coefficients of the covariance model (eq. 4-2), fewer than "
            f"{min_targets_per_coefficient:g} per coefficient "
            f"({math.ceil(min_targets_per_coefficient * p_max)}); probe more poses, or accept the "
            "sparse model with its held-out errors (--allow-few-targets)"
        )
    rng = as_generator(seed)
    val = np.zeros(n, bool)
    val[rng.choice(n, n_val, replace=False)] = True
    _check_levels(stats.factors[~val])
    if factor_ranges is None:
        low, high = stats.factors.min(axis=0), stats.factors.max(axis=0)
    else:
        low, high = (np.asarray(r, float) for r in factor_ranges)
    empty = RepeatabilityModel(low, high, (), n - n_val, n_val)
    z = empty.normalise(stats.factors)
    measured = np.hstack([stats.std, stats.cov])
    fits = []
    for j, name in enumerate(STD_OUTPUTS + COVARIANCE_OUTPUTS):
        degrees = STD_DEGREES if name in STD_OUTPUTS else COVARIANCE_DEGREES
        fits.append(_fit_output(name, separable_design(z, degrees), measured[:, j], val))
    return RepeatabilityModel(low, high, tuple(fits), n - n_val, n_val)


def _fit_output(name: str, a: np.ndarray, y: np.ndarray, val: np.ndarray) -> OutputFit:
    a_fit, y_fit = a[~val], y[~val]
    m, p = a_fit.shape
    res = least_squares(lambda c: (a_fit @ c - y_fit, a_fit), np.zeros(p), require_full_rank=True)
    rss = 2.0 * res.cost
    s2 = rss / (m - p)
    tss = float(np.sum((y_fit - y_fit.mean()) ** 2))
    r2 = 1.0 - rss / tss if tss > 0 else 1.0
    rel = absolute = rms = None
    if val.any():
        pred = a[val] @ res.x
        if name in STD_OUTPUTS:
            pred = np.maximum(pred, 0.0)
        diff = np.abs(pred - y[val])
        absolute = float(diff.max())
        nonzero = y[val] != 0
        rel = float(np.max(diff[nonzero] / np.abs(y[val][nonzero]))) if nonzero.any() else None
        size = float(np.sum(y[val] ** 2))
        rms = float(np.sqrt(np.sum(diff**2) / size)) if size > 0 else None
    u = np.sqrt(s2 * np.diag(res.covariance()))
    return OutputFit(name, res.x, u, float(r2), rel, absolute, rms)
