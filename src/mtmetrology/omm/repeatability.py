"""Probing repeatability of on-machine measurement: per-target statistics and pose models.

From replicated probing records (one row per touch), :func:`target_statistics` gives, per
target pose, the sample standard deviations of the X, Y, Z readings and of their normal
and tangential projections, and the covariances cov(X,Y), cov(X,Z), cov(Y,Z), cov(N,T),
with the first touch of every group discarded (its preceding motion differs: hysteresis).
:func:`fit_repeatability_model` fits the separable polynomial models of Sepahi Boroujeni
(2021), eqs. 4-1 (standard deviations, 22 coefficients) and 4-2 (covariances, 36
coefficients), on factors normalised to [−1, 1], by the library's least-squares core; the
:class:`RepeatabilityModel` predicts a positive-semidefinite 3×3 covariance (and the 5×5
``v_i`` with zero rotary rows) for any pose and approach inside the fitted range.

Factors, in this order: φ (polar angle of the target normal from machine Z), θ (azimuth
from machine Y), B and C (rotary positions), X_T, Y_T, Z_T (target position). Internally
rad and mm; standard deviations in mm, covariances in mm².

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
from mtmetrology.omm.drift import (
    CUBIC_COEFFICIENTS,
    MIN_CUBIC_POINTS,
    detrend_cubic,
    detrend_cubic_stack,
)
from mtmetrology.optimize import least_squares
from mtmetrology.rng import SeedLike, as_generator
from mtmetrology.units import from_internal, to_internal

__all__ = [
    "COVARIANCE_OUTPUTS",
    "FACTORS",
    "FACTOR_UNITS",
    "MIN_TARGETS_PER_COEFFICIENT",
    "STD_OUTPUTS",
    "VALIDATION_WARNING",
    "OutputFit",
    "PoseRangeWarning",
    "RepeatabilityModel",
    "TargetStatistics",
    "factors_from_file_units",
    "fit_repeatability_model",
    "lateral_deviation_threshold",
    "normal_tangential",
    "sphere_normal",
    "target_statistics",
    "time_ordered_groups",
]

FACTORS = ("phi", "theta", "B", "C", "X_T", "Y_T", "Z_T")
#: Fewest fitting targets per coefficient a model is fitted with unless asked: with 36
#: coefficients on 38 targets the held-out errors of cov(X,Y) reached 5 200 % (issue 18).
MIN_TARGETS_PER_COEFFICIENT = 3.0
#: Held-out RMS error, as a fraction of the RMS of the held-out values, above which an
#: output is flagged: the model then predicts its values no better than half their size.
VALIDATION_WARNING = 0.5
FACTOR_UNITS = ("deg", "deg", "deg", "deg", "mm", "mm", "mm")
STD_OUTPUTS = ("sigma_X", "sigma_Y", "sigma_Z", "sigma_N", "sigma_T")
COVARIANCE_OUTPUTS = ("cov_XY", "cov_XZ", "cov_YZ", "cov_NT")
# Polynomial degree of each factor (order of FACTORS) in eq. 4-1; eq. 4-2 uses 5 for all.
_STD_DEGREES = (2, 4, 3, 3, 3, 3, 3)
_COV_DEGREES = (5,) * 7
_RANGE_SLACK = 1e-9  # normalised units: rounding of the range limits themselves


class PoseRangeWarning(UserWarning):
    """A pose outside the range the repeatability model was fitted on."""


def sphere_normal(phi: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Outward unit normal of a sphere target (Sepahi Boroujeni (2021), eq. A.4-2).

    Parameters
    ----------
    phi, theta : (...,) array, rad
        Polar angle from machine Z and azimuth from machine Y (θ = 90° points along X).

    Returns
    -------
    (..., 3) ndarray
        n̂ = (sin φ sin θ, sin φ cos θ, cos φ).

    Examples
    --------
    >>> sphere_normal(np.pi / 2, np.pi / 2).round(12)
    array([1., 0., 0.])
    """
    phi, theta = np.asarray(phi, float), np.asarray(theta, float)
    return np.stack(
        [np.sin(phi) * np.sin(theta), np.sin(phi) * np.cos(theta), np.cos(phi)], axis=-1
    )


def normal_tangential(
    points: np.ndarray, centre: np.ndarray, normal: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Normal and tangential projections of probed points (Sepahi Boroujeni (2021), A.4).

    Parameters
    ----------
    points : (..., 3) array, mm
        Probed points OP.
    centre : (..., 3) array, mm
        Sphere centre OC (or any point on the nominal normal line of the target).
    normal : (..., 3) array
        Unit normal n̂ of the target.

    Returns
    -------
    N, T : (...,) ndarray, mm
        N = CP·n̂ and T = √(‖CP‖² − N²) with CP = OP − OC (eqs. A.4-1 to A.4-3).

    Examples
    --------
    Appendix A: target (φ, θ) = (18°, 144°), OC = (76.2, 80, −78.919) mm and
    OP = (78.9655, 76.195, −64.443) mm give N = 15.2211 mm and T ≈ 0.0009 mm:

    >>> n = sphere_normal(np.radians(18.0), np.radians(144.0))
    >>> N, T = normal_tangential([78.9655, 76.195, -64.443], [76.2, 80.0, -78.919], n)
    >>> round(float(N), 4), round(float(T), 4)
    (15.2211, 0.0009)
    """
    cp = np.asarray(points, float) - np.asarray(centre, float)
    n = np.sum(cp * np.asarray(normal, float), axis=-1)
    # Clip at 0: for a point on the normal line, rounding can make ‖CP‖² − N² slightly < 0.
    t = np.sqrt(np.maximum(np.sum(cp * cp, axis=-1) - n * n, 0.0))
    return n, t


def lateral_deviation_threshold(radius: float, resolution: float) -> float:
    """Lateral tip deviation that changes the probed distance by one resolution step.

    Parameters
    ----------
    radius : float, mm
        Sphere radius plus stylus tip radius, R.
    resolution : float, mm
        Resolution of the recorded coordinates, d.

    Returns
    -------
    float, mm
        b′ = √(2 R d): a lateral deviation b′ changes the approach distance by
        d ≈ b′²/(2R) (Sepahi Boroujeni (2021), §4; second order), so lateral randomness
        smaller than b′ is invisible in the readings.

    Examples
    --------
    R = 12.7 + 3.0 mm and d = 0.5 µm give 125.3 µm:

    >>> round(lateral_deviation_threshold(15.7, 0.0005) * 1000, 1)
    125.3
    """
    if not (math.isfinite(radius) and radius > 0 and math.isfinite(resolution)):
        raise InputError("radius and resolution must be finite, radius > 0")
    if resolution < 0:
        raise InputError("resolution must be >= 0")
    return math.sqrt(2.0 * radius * resolution)


@dataclass(frozen=True)
class TargetStatistics:
    """Per-target repeatability statistics (first touch discarded).

    Attributes
    ----------
    targets : tuple of str
        Target ids, in first-appearance order.
    factors : (n, 7) ndarray
        φ, θ, B, C (rad), X_T, Y_T, Z_T (mm) of each target.
    n_touches : (n,) ndarray of int
        Touches used (after discarding the first).
    mean : (n, 3) ndarray, mm
        Mean X, Y, Z readings.
    std : (n, 5) ndarray, mm
        Sample standard deviations of X, Y, Z, N, T (:data:`STD_OUTPUTS`).
    cov : (n, 4) ndarray, mm²
        Sample covariances (X,Y), (X,Z), (Y,Z), (N,T) (:data:`COVARIANCE_OUTPUTS`).
    zero_variance : (n, 3) ndarray of bool
        X, Y, Z readings that did not change at all: the scale resolution hides the
        scatter (an approach along an axis); approach slightly off the axes instead.
    drift : {"none", "cubic"}
        "cubic": ``std`` and ``cov`` are those of the residuals of a cubic drift in time
        (:func:`~mtmetrology.omm.drift.detrend_cubic`, n − 4 degrees of freedom).
    std_raw : (n, 5) ndarray, mm
        Standard deviations of the readings themselves (ddof = 1), drift included; equal
        to ``std`` when ``drift`` is "none".
    """

    targets: tuple[str, ...]
    factors: np.ndarray
    n_touches: np.ndarray
    mean: np.ndarray
    std: np.ndarray
    cov: np.ndarray
    zero_variance: np.ndarray
    drift: str = "none"
    std_raw: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.targets)

    def to_dict(self) -> dict:
        """JSON rows in file units (deg, mm, µm, µm²)."""
        rows = []
        for i, name in enumerate(self.targets):
            row = {"target": name, "n_touches": int(self.n_touches[i])}
            row.update(_factors_to_file(self.factors[i]))
            row.update({f"mean_{a}": float(v) for a, v in zip("XYZ", self.mean[i], strict=True)})
            row.update(_outputs_to_file(self.std[i], self.cov[i]))
            if self.drift != "none" and self.std_raw is not None:
                row.update(
                    {
                        f"{n}_raw": float(from_internal(v, "µm"))
                        for n, v in zip(STD_OUTPUTS, self.std_raw[i], strict=True)
                    }
                )
            row["zero_variance"] = [
                a for a, z in zip("XYZ", self.zero_variance[i], strict=True) if z
            ]
            rows.append(row)
        drift = {"model": self.drift}
        if self.drift == "cubic":
            drift.update(abscissa="time", ddof=CUBIC_COEFFICIENTS)
        return {"units": _file_units(), "drift": drift, "targets": rows}


def _factors_to_file(f: np.ndarray) -> dict:
    return {
        name: float(from_internal(v, unit))
        for name, v, unit in zip(FACTORS, f, FACTOR_UNITS, strict=True)
    }


def _outputs_to_file(std: np.ndarray, cov: np.ndarray) -> dict:
    out = {n: float(from_internal(v, "µm")) for n, v in zip(STD_OUTPUTS, std, strict=True)}
    out.update(
        {
            n: float(from_internal(from_internal(v, "µm"), "µm"))
            for n, v in zip(COVARIANCE_OUTPUTS, cov, strict=True)
        }
    )
    return out


def _file_units() -> dict:
    units = dict(zip(FACTORS, FACTOR_UNITS, strict=True))
    units.update({n: "µm" for n in STD_OUTPUTS})
    units.update({n: "µm²" for n in COVARIANCE_OUTPUTS})
    return units


def time_ordered_groups(target, time) -> list[tuple[str, np.ndarray]]:
    """Row indices of each target's touches in time order, targets in first-appearance order.

    Parameters
    ----------
    target : (m,) sequence of str
        Target id of each touch.
    time : (m,) array
        Touch time (ties keep the file order).

    Returns
    -------
    list of (str, ndarray of int)

    Examples
    --------
    >>> [(t, i.tolist()) for t, i in time_ordered_groups(["b", "a", "b"], [2.0, 0.0, 1.0])]
    [('b', [2, 0]), ('a', [1])]
    """
    names, first, inverse = np.unique(np.asarray(target), return_index=True, return_inverse=True)
    order = np.lexsort((np.asarray(time, float), inverse))  # by target, then time (stable)
    chunks = np.split(order, np.cumsum(np.bincount(inverse, minlength=names.size))[:-1])
    return [(str(names[g]), chunks[g]) for g in np.argsort(first)]  # first-appearance order


def target_statistics(
    target: list[str],
    factors: np.ndarray,
    readings: np.ndarray,
    normal: np.ndarray,
    time: np.ndarray,
    *,
    centre: np.ndarray | None = None,
    discard_first: bool = True,
    drift: str = "none",
    where: str = "records",
) -> TargetStatistics:
    """Per-target sample standard deviations and covariances of replicated probing.

    Parameters
    ----------
    target : list of str, length m
        Target id of each touch.
    factors : (m, 7) array
        φ, θ, B, C (rad), X_T, Y_T, Z_T (mm): constant within a target.
    readings : (m, 3) array, mm
        Recorded X, Y, Z of each touch.
    normal : (m, 3) array
        Unit outward normal of the target (the probe approaches along −n̂).
    time : (m,) array, s
        Touch time: orders the touches of a target (the first is discarded) and is the
        abscissa of the drift fit.
    centre : (m, 3) array, mm, optional
        Sphere centre for the N/T projections; by default the line along n̂ through the
        target's mean reading (N then scatters about 0 and T is the lateral distance).
    discard_first : bool, default True
        Drop the first touch of each target (hysteresis of the preceding motion,
        Sepahi Boroujeni (2021), §4).
    drift : {"none", "cubic"}, default "none"
        "cubic": remove a cubic drift in time from each of the series X, Y, Z, N, T of a
        target (:func:`~mtmetrology.omm.drift.detrend_cubic`) and compute the standard
        deviations and covariances from the residuals with n − 4 degrees of freedom.
    where : str
        Name of the source (file) for error messages.

    Returns
    -------
    TargetStatistics

    Raises
    ------
    InputError
        A target with fewer than 3 usable touches (6 with ``drift="cubic"``), with
        changing pose factors, or an unknown ``drift``.

    Notes
    -----
    Without drift removal, s² = Σ (x − x̄)² / (n − 1); with it, s² = Σ r² / (n − 4),
    r the residuals of the cubic, whose 4 coefficients (the mean among them) use 4
    degrees of freedom (Sepahi Boroujeni (2021), §4: repeatability = standard deviation
    of the residuals of the cubic fitted to each series). The abscissa is the touch
    time, which equals the thesis's iteration index when touches are equally spaced
    (the residuals do not change under an affine change of the abscissa) and follows
    the thermal drift better when they are not (shuffled tests).

    Examples
    --------
    Six touches on a pure cubic drift (first touch discarded) have zero repeatability
    once the drift is removed:

    >>> t = np.arange(7.0)
    >>> x = to_internal(0.5 * t - 0.1 * t**2 + 0.02 * t**3, "µm")
    >>> readings = np.column_stack([x, 2 * x, np.zeros(7)])
    >>> n = np.tile([0.0, 0.0, 1.0], (7, 1))
    >>> st = target_statistics(["a"] * 7, np.zeros((7, 7)), readings, n, t, drift="cubic")
    >>> bool(st.std[0, 0] < 1e-12 < st.std_raw[0, 0])
    True
    """
    if drift not in ("none", "cubic"):
        raise InputError(f"drift: must be 'none' or 'cubic', got {drift!r}")
    need = MIN_CUBIC_POINTS if drift == "cubic" else 3
    groups = []
    for name, idx in time_ordered_groups(target, time):
        if not np.all(factors[idx] == factors[idx[0]]):
            raise InputError(f"{where}: target {name!r}: pose factors change between touches")
        if discard_first:
            idx = idx[1:]
        if idx.size < need:
            raise InputError(
                f"{where}: target {name!r} has {idx.size} usable touches; "
                + (
                    f"cubic drift removal needs at least {need} after the first is discarded"
                    if drift == "cubic"
                    else f"repeatability needs at least {need} after the first is discarded"
                )
            )
        groups.append((name, idx))
    k = len(groups)
    mean, std, cov, std_raw = np.empty((k, 3)), np.empty((k, 5)), np.empty((k, 4)), np.empty((k, 5))
    zero = np.empty((k, 3), bool)
    sizes = np.array([idx.size for _, idx in groups])
    for size in np.unique(sizes):  # targets with as many touches, stacked (g, n, ·)
        members = np.flatnonzero(sizes == size)
        idx = np.stack([groups[g][1] for g in members])
        p = readings[idx]
        mean[members] = p.mean(axis=1)
        origin = centre[idx] if centre is not None else mean[members][:, None, :]
        n_proj, t_proj = normal_tangential(p, origin, normal[idx])
        series = np.concatenate([p, n_proj[..., None], t_proj[..., None]], axis=2)  # X Y Z N T
        d = series - series.mean(axis=1, keepdims=True)
        c5 = raw = np.einsum("gni,gnj->gij", d, d) / (size - 1)
        if drift == "cubic":
            r = _drift_residuals(series, time[idx], [groups[g][0] for g in members], where)
            c5 = np.einsum("gni,gnj->gij", r, r) / (size - CUBIC_COEFFICIENTS)
        std[members] = np.sqrt(np.einsum("gii->gi", c5))
        cov[members] = c5[:, [0, 0, 1, 3], [1, 2, 2, 4]]  # XY, XZ, YZ, NT
        std_raw[members] = np.sqrt(np.einsum("gii->gi", raw))
        zero[members] = np.ptp(p, axis=1) == 0
    return TargetStatistics(
        targets=tuple(name for name, _ in groups),
        factors=np.array([factors[idx[0]] for _, idx in groups]),
        n_touches=sizes,
        mean=mean,
        std=std,
        cov=cov,
        zero_variance=zero,
        drift=drift,
        std_raw=std_raw,
    )


def _drift_residuals(series, time, names, where: str) -> np.ndarray:
    """Cubic-drift residuals of stacked (g, n, 5) series; a refused target is named."""
    try:
        return detrend_cubic_stack(series, time, where=where)
    except InputError:
        for s, t, name in zip(series, time, names, strict=True):
            detrend_cubic(s, t, where=f"{where}: target {name!r}")
        raise


def _design(z: np.ndarray, degrees: tuple[int, ...]) -> np.ndarray:
    """Columns 1, z_f, z_f², …, z_f^deg for each factor f (separable, no cross terms)."""
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
            degrees = _STD_DEGREES if fit.name in STD_OUTPUTS else _COV_DEGREES
            value = _design(z, degrees) @ fit.coefficients
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
        need = max(_STD_DEGREES[k], _COV_DEGREES[k]) + 1
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
    p_max = _design(np.zeros((1, 7)), _COV_DEGREES).shape[1]
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
        degrees = _STD_DEGREES if name in STD_OUTPUTS else _COV_DEGREES
        fits.append(_fit_output(name, _design(z, degrees), measured[:, j], val))
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


def factors_from_file_units(
    phi: np.ndarray, theta: np.ndarray, b: np.ndarray, c: np.ndarray, x, y, z
) -> np.ndarray:
    """(m, 7) internal factors from deg (φ, θ, B, C) and mm (X_T, Y_T, Z_T)."""
    return np.column_stack(
        [
            to_internal(np.asarray(v, float), u)
            for v, u in zip((phi, theta, b, c, x, y, z), FACTOR_UNITS, strict=True)
        ]
    )
