"""Probing repeatability of on-machine measurement: per-target statistics.

From replicated probing records (one row per touch), :func:`target_statistics` gives, per
target pose, the sample standard deviations of the X, Y, Z readings and of their normal
and tangential projections, and the covariances cov(X,Y), cov(X,Z), cov(Y,Z), cov(N,T),
with the first touch of every group discarded (its preceding motion differs: hysteresis).
The pose models fitted on them are in :mod:`mtmetrology.omm.repeatability_model`.

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
from dataclasses import dataclass

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.omm.drift import (
    CUBIC_COEFFICIENTS,
    MIN_CUBIC_POINTS,
    detrend_cubic,
    detrend_cubic_stack,
)
from mtmetrology.units import from_internal, to_internal

__all__ = [
    "COVARIANCE_OUTPUTS",
    "FACTORS",
    "FACTOR_UNITS",
    "STD_OUTPUTS",
    "TargetStatistics",
    "factors_from_file_units",
    "lateral_deviation_threshold",
    "normal_tangential",
    "sphere_normal",
    "target_statistics",
    "time_ordered_groups",
]

FACTORS = ("phi", "theta", "B", "C", "X_T", "Y_T", "Z_T")
FACTOR_UNITS = ("deg", "deg", "deg", "deg", "mm", "mm", "mm")
STD_OUTPUTS = ("sigma_X", "sigma_Y", "sigma_Z", "sigma_N", "sigma_T")
COVARIANCE_OUTPUTS = ("cov_XY", "cov_XZ", "cov_YZ", "cov_NT")


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
