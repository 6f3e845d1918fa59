"""Features (GD&T characteristics) of probed point sets, for the uncertainty engine.

A feature maps the stylus-centre points of one measurement task, ``(n, 3)`` mm, to one
or more values (Sepahi Boroujeni (2021), Ch. 6: a feature is a function of the 3n point
coordinates).  Every feature offers

* ``value(points)`` for points ``(..., n, 3)``, vectorised over the leading (Monte Carlo
  trial) axes through the batched fits of :mod:`mtmetrology.fitting.batch`; it returns
  ``(...,)`` for a scalar feature and ``(..., k)`` for ``k`` outputs;
* ``jacobian(points)`` for one point set ``(n, 3)``: the analytic ``(k, 3n)`` matrix
  ``∂g/∂q`` with the coordinates flattened point by point (x1, y1, z1, x2, ...), for GUF
  propagation ``U_g = G U_q Gᵀ`` (Sepahi Boroujeni (2021), Ch. 6; JCGM 102:2011, §6.2).

Jacobians of fitted features come from the least-squares fits' first-order
implicit-function derivatives (:mod:`mtmetrology.fitting.least_squares`), exact at
zero form error and first-order accurate otherwise, as the GUF linearisation is.
Form errors (max − min residual) are differentiated at the extreme points, which is
exact where they are unique (almost everywhere).  The minimum-zone (ISO 1101 Chebyshev)
form errors and minimax sizes are in :mod:`mtmetrology.fitting.zone_features`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np

from mtmetrology.errors import ConvergenceError
from mtmetrology.fitting import batch, batch_cylinders
from mtmetrology.fitting.least_squares import (
    FitResult,
    fit_circle,
    fit_cylinder,
    fit_plane,
    fit_sphere,
)

__all__ = [
    "BallCentre",
    "CircleCentre",
    "CircleDiameter",
    "CylinderDiameter",
    "Cylindricity",
    "Feature",
    "Flatness",
    "GaugeLength",
    "Roundness",
    "SphereDiameter",
    "Sphericity",
]


@runtime_checkable
class Feature(Protocol):
    """What the uncertainty engine needs from a feature."""

    name: str
    unit: str
    min_points: int  # the fewest points it is defined on

    @property
    def output_names(self) -> tuple[str, ...]: ...

    def value(self, points: object) -> np.ndarray: ...

    def jacobian(self, points: object) -> np.ndarray: ...


def stacked_point_sets(
    points: object, name: str, min_points: int
) -> tuple[np.ndarray, tuple[int, ...]]:
    """Points (..., n, 3) -> stacked (K, n, 3) and the leading shape, for a feature's
    ``value``; a ``ValueError`` naming the feature on a wrong shape or too few points."""
    arr = np.asarray(points, dtype=float)
    if arr.ndim < 2 or arr.shape[-1] != 3:
        raise ValueError(f"{name}: points must have shape (..., n, 3), got {arr.shape}")
    if arr.shape[-2] < min_points:
        raise ValueError(f"{name}: needs at least {min_points} points, got {arr.shape[-2]}")
    lead = arr.shape[:-2]
    return arr.reshape((-1, *arr.shape[-2:])), lead


def single_point_set(points: object, name: str, min_points: int) -> np.ndarray:
    """One point set (n, 3), n ≥ ``min_points``, for a feature's ``jacobian``; a
    ``ValueError`` naming the feature otherwise."""
    arr = np.asarray(points, dtype=float)
    if arr.ndim != 2 or arr.shape[1] != 3 or arr.shape[0] < min_points:
        raise ValueError(
            f"{name}: jacobian needs one point set of shape (n >= {min_points}, 3), got {arr.shape}"
        )
    return arr


def _tip(tip_diameter: float) -> float:
    d = float(tip_diameter)
    if not math.isfinite(d) or d < 0:
        raise ValueError(f"tip_diameter must be a finite length >= 0 mm, got {tip_diameter!r}")
    return d


def _peak_to_valley_jacobian(fit: FitResult) -> np.ndarray:
    """d(max − min residual)/dP, flattened to (1, n·dim)."""
    rj = fit.residual_jacobian()  # (n, n, dim)
    i_max, i_min = int(np.argmax(fit.residuals)), int(np.argmin(fit.residuals))
    return (rj[i_max] - rj[i_min]).reshape(1, -1)


class ScalarFeature:
    """One output, named after the feature."""

    name: str

    @property
    def output_names(self) -> tuple[str, ...]:
        return (self.name,)


class _Position:
    """Three outputs, the x, y, z coordinates of a point, mm."""

    name: str

    @property
    def output_names(self) -> tuple[str, ...]:
        return (f"{self.name}_x", f"{self.name}_y", f"{self.name}_z")


class TipCompensatedSize(ScalarFeature):
    """A size with a validated ``tip_diameter``, added inside (``inner``: bore, cavity)
    and subtracted outside (shaft, ball); GaugeLength has no ``inner``."""

    tip_diameter: float
    inner: bool

    def __post_init__(self) -> None:
        object.__setattr__(self, "tip_diameter", _tip(self.tip_diameter))

    def _offset(self) -> float:
        return self.tip_diameter if self.inner else -self.tip_diameter


@dataclass(frozen=True)
class GaugeLength(TipCompensatedSize):
    """Bipoint length ``l = ‖q2 − q1‖ − d_tip`` (Sepahi Boroujeni (2021), eq. 6-20).

    Points ``(..., 2, 3)``: the stylus-centre points probed on the two faces.  Sepahi
    Boroujeni (2021), Table 7-1, gives 499.9966 mm with ``d_tip`` = 5.925 mm.

    Examples
    --------
    >>> q = [[-178.6461, -178.6461, 53.1107], [179.1009, 179.0881, 53.1067]]
    >>> round(float(GaugeLength(tip_diameter=5.925).value(q)), 4)
    499.9966
    """

    tip_diameter: float
    name: str = "gauge_length"
    unit: str = "mm"
    min_points: ClassVar[int] = 2

    def value(self, points: object) -> np.ndarray:
        arr = np.asarray(points, dtype=float)
        if arr.ndim < 2 or arr.shape[-2:] != (2, 3):
            raise ValueError(f"{self.name}: points must have shape (..., 2, 3), got {arr.shape}")
        return np.linalg.norm(arr[..., 1, :] - arr[..., 0, :], axis=-1) - self.tip_diameter

    def jacobian(self, points: object) -> np.ndarray:
        """``[−e, e]`` with ``e = (q2 − q1)/‖q2 − q1‖``, shape (1, 6)."""
        arr = np.asarray(points, dtype=float)
        if arr.shape != (2, 3):
            raise ValueError(f"{self.name}: jacobian needs points of shape (2, 3), got {arr.shape}")
        diff = arr[1] - arr[0]
        e = diff / np.linalg.norm(diff)
        return np.concatenate([-e, e])[None, :]


@dataclass(frozen=True)
class SphereDiameter(TipCompensatedSize):
    """Least-squares sphere diameter with tip compensation: ``2R ∓ d_tip``.

    ``inner=False`` (a ball probed from outside): ``D = 2 R_fit − d_tip``;
    ``inner=True`` (a spherical cavity): ``D = 2 R_fit + d_tip`` (the tip correction the
    thesis leaves implicit).
    """

    tip_diameter: float = 0.0
    inner: bool = False
    name: str = "sphere_diameter"
    unit: str = "mm"
    min_points: ClassVar[int] = 4

    def value(self, points: object) -> np.ndarray:
        stack, lead = stacked_point_sets(points, self.name, self.min_points)
        return (2.0 * batch.fit_spheres(stack).radii + self._offset()).reshape(lead)

    def jacobian(self, points: object) -> np.ndarray:
        fit = fit_sphere(single_point_set(points, self.name, self.min_points))
        return 2.0 * fit.parameter_jacobian[3].reshape(1, -1)


@dataclass(frozen=True)
class Sphericity(ScalarFeature):
    """Least-squares sphericity: max − min residual of the LS sphere (Sepahi Boroujeni
    (2021), Ch. 6)."""

    name: str = "sphericity"
    unit: str = "mm"
    min_points: ClassVar[int] = 4

    def value(self, points: object) -> np.ndarray:
        stack, lead = stacked_point_sets(points, self.name, self.min_points)
        return batch.fit_spheres(stack).form_error.reshape(lead)

    def jacobian(self, points: object) -> np.ndarray:
        fit = fit_sphere(single_point_set(points, self.name, self.min_points))
        return _peak_to_valley_jacobian(fit)


@dataclass(frozen=True)
class CircleDiameter(TipCompensatedSize):
    """Least-squares circle diameter (in the LS plane) with tip compensation.

    ``inner=True`` (bore, ring gauge probed from inside): ``D = 2 R_fit + d_tip``;
    ``inner=False`` (a shaft): ``D = 2 R_fit − d_tip`` (Mutilba et al. (2019), eq. 4).
    """

    inner: bool = True
    tip_diameter: float = 0.0
    name: str = "circle_diameter"
    unit: str = "mm"
    min_points: ClassVar[int] = 3

    def value(self, points: object) -> np.ndarray:
        stack, lead = stacked_point_sets(points, self.name, self.min_points)
        return (2.0 * batch.fit_circles(stack).radii + self._offset()).reshape(lead)

    def jacobian(self, points: object) -> np.ndarray:
        fit = fit_circle(single_point_set(points, self.name, self.min_points))
        return 2.0 * fit.parameter_jacobian[6].reshape(1, -1)


@dataclass(frozen=True)
class Roundness(ScalarFeature):
    """Least-squares roundness: max − min radial residual in the LS plane."""

    name: str = "roundness"
    unit: str = "mm"
    min_points: ClassVar[int] = 3

    def value(self, points: object) -> np.ndarray:
        stack, lead = stacked_point_sets(points, self.name, self.min_points)
        return batch.fit_circles(stack).form_error.reshape(lead)

    def jacobian(self, points: object) -> np.ndarray:
        fit = fit_circle(single_point_set(points, self.name, self.min_points))
        return _peak_to_valley_jacobian(fit)


@dataclass(frozen=True)
class Flatness(ScalarFeature):
    """Least-squares flatness: max − min signed distance to the LS plane."""

    name: str = "flatness"
    unit: str = "mm"
    min_points: ClassVar[int] = 3

    def value(self, points: object) -> np.ndarray:
        stack, lead = stacked_point_sets(points, self.name, self.min_points)
        return batch.fit_planes(stack).form_error.reshape(lead)

    def jacobian(self, points: object) -> np.ndarray:
        fit = fit_plane(single_point_set(points, self.name, self.min_points))
        return _peak_to_valley_jacobian(fit)


@dataclass(frozen=True)
class BallCentre(_Position):
    """Ball centre (x, y, z) from probed points: LS sphere, or centre only with a known
    radius (SAMBA: ball radius + effective tip radius; Sepahi Boroujeni (2021), Ch. 5 and 6)."""

    radius: float | None = None
    name: str = "ball_centre"
    unit: str = "mm"
    min_points: ClassVar[int] = 4

    def __post_init__(self) -> None:
        if self.radius is not None:
            r = float(self.radius)
            if not math.isfinite(r) or r <= 0:
                raise ValueError(f"radius must be a positive length, got {self.radius!r}")
            object.__setattr__(self, "radius", r)

    def value(self, points: object) -> np.ndarray:
        stack, lead = stacked_point_sets(points, self.name, self.min_points)
        return batch.fit_spheres(stack, radius=self.radius).centres.reshape((*lead, 3))

    def jacobian(self, points: object) -> np.ndarray:
        fit = fit_sphere(single_point_set(points, self.name, self.min_points), radius=self.radius)
        return fit.parameter_jacobian[:3].reshape(3, -1)


@dataclass(frozen=True)
class CircleCentre(_Position):
    """Centre (x, y, z) of the least-squares circle in its least-squares plane.

    The position of a bore or boss from one probed cross-section (ISO 1101 position and
    concentricity refer to it; Sepahi Boroujeni (2021), Ch. 6: a feature is a function
    of the 3n point coordinates).  Points ``(..., n, 3)``, n ≥ 3, not collinear.

    Examples
    --------
    >>> t = np.linspace(0, 2 * np.pi, 6, endpoint=False)
    >>> ring = np.c_[10 + 5 * np.cos(t), -3 + 5 * np.sin(t), np.full(6, 2.0)]
    >>> CircleCentre().value(ring).round(12).tolist()
    [10.0, -3.0, 2.0]
    """

    name: str = "circle_centre"
    unit: str = "mm"
    min_points: ClassVar[int] = 3

    def value(self, points: object) -> np.ndarray:
        stack, lead = stacked_point_sets(points, self.name, self.min_points)
        return batch.fit_circles(stack).centres.reshape((*lead, 3))

    def jacobian(self, points: object) -> np.ndarray:
        """Rows 0–2 of :func:`fit_circle`'s parameter Jacobian, shape (3, 3n)."""
        fit = fit_circle(single_point_set(points, self.name, self.min_points))
        return fit.parameter_jacobian[:3].reshape(3, -1)


@dataclass(frozen=True)
class CylinderDiameter(TipCompensatedSize):
    """Least-squares cylinder diameter with tip compensation.

    ``inner=True`` (a bore probed from inside): ``D = 2 R_fit + d_tip``;
    ``inner=False`` (a shaft): ``D = 2 R_fit − d_tip``, the convention of
    :class:`CircleDiameter` (Mutilba et al. (2019), eq. 4, extended along the axis).

    Parameters
    ----------
    inner : bool
        Bore (True) or shaft (False).
    tip_diameter : float, mm
        Effective tip diameter ``d_tip`` ≥ 0.

    Notes
    -----
    ``R_fit`` minimises ``Σ (ρ_i − R)²`` over the axis and R, ``ρ_i`` the distance of the
    stylus-centre point i from the axis (ISO 14405-1:2016 (GG) least-squares size;
    Forbes, NPL DITC 140/89, §4.8).  ``value`` fits all stacked sets at once with
    :func:`mtmetrology.fitting.batch_cylinders.fit_cylinders` (about 2.5 s for 10⁵ sets of 25
    points on one core; a loop of :func:`fit_cylinder` takes about 1000 times longer)
    and raises :class:`mtmetrology.errors.ConvergenceError` if a set does not converge;
    ``jacobian`` is ``2 ∂R/∂q`` from :func:`fit_cylinder`'s first-order parameter
    Jacobian (exact at zero form error).  Points ``(..., n, 3)``, n ≥ 5, not coplanar.

    References
    ----------
    ISO 14405-1:2016, *Geometrical product specifications (GPS) — Dimensional
    tolerancing — Part 1: Linear sizes*.
    Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with
    On-Machine Tool Metrology*. PhD thesis, Polytechnique Montréal, Ch. 6.

    Examples
    --------
    >>> t = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    >>> ring = np.c_[12 * np.cos(t), 12 * np.sin(t), np.zeros(8)]
    >>> bore = np.r_[ring, ring + [0, 0, -15]]  # stylus centres, tip Ø 6 mm
    >>> round(float(CylinderDiameter(inner=True, tip_diameter=6.0).value(bore)), 12)
    30.0
    """

    inner: bool = True
    tip_diameter: float = 0.0
    name: str = "cylinder_diameter"
    unit: str = "mm"
    min_points: ClassVar[int] = 5

    def value(self, points: object) -> np.ndarray:
        stack, lead = stacked_point_sets(points, self.name, self.min_points)
        return (2.0 * _cylinders(stack, self.name).radii + self._offset()).reshape(lead)

    def jacobian(self, points: object) -> np.ndarray:
        fit = fit_cylinder(single_point_set(points, self.name, self.min_points))
        return 2.0 * fit.parameter_jacobian[6].reshape(1, -1)


@dataclass(frozen=True)
class Cylindricity(ScalarFeature):
    """Least-squares cylindricity: max − min radial residual of the LS cylinder.

    An upper bound of the ISO 12180-1 minimum-zone cylindricity
    (:class:`~mtmetrology.fitting.MinimumZoneCylindricity`).  ``value`` is batched as
    for :class:`CylinderDiameter`; ``jacobian`` differentiates the two extreme residuals
    (exact where they are unique).  Points ``(..., n, 3)``, n ≥ 5, not coplanar.

    Examples
    --------
    >>> t = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    >>> r = 12 + 0.001 * np.cos(4 * t)
    >>> ring = np.c_[r * np.cos(t), r * np.sin(t), np.zeros(8)]
    >>> round(float(Cylindricity().value(np.r_[ring, ring + [0, 0, 15]])), 9)
    0.002
    """

    name: str = "cylindricity"
    unit: str = "mm"
    min_points: ClassVar[int] = 5

    def value(self, points: object) -> np.ndarray:
        stack, lead = stacked_point_sets(points, self.name, self.min_points)
        return _cylinders(stack, self.name).form_error.reshape(lead)

    def jacobian(self, points: object) -> np.ndarray:
        fit = fit_cylinder(single_point_set(points, self.name, self.min_points))
        return _peak_to_valley_jacobian(fit)


def _cylinders(stack: np.ndarray, name: str) -> batch_cylinders.BatchCylinderFit:
    """Batched cylinder fits; a set that did not converge raises rather than give a number."""
    fit = batch_cylinders.fit_cylinders(stack)
    if not fit.success.all():
        first = int(np.argmin(fit.success))
        raise ConvergenceError(f"{name}: {fit.message}; first: set {first}")
    return fit
