"""Probe-tip compensation: from stylus-centre points to the workpiece surface.

A touch probe records the centre of its spherical stylus tip, which lies one tip radius
``r_tip`` from the surface along the surface normal, on the probe's side.  Fitting the
stylus-centre points gives an element offset from the surface by ``r_tip``:

* an outer feature (ball, shaft, male cone), probed from outside, has the material
  inside: ``R_surface = R_fit − r_tip``;
* an inner feature (bore, ring gauge, female cone), probed from inside, has the
  material outside: ``R_surface = R_fit + r_tip``;
* a plane moves by ``r_tip`` against the probing side; a cone keeps its half-angle ψ
  and its apex moves along the axis by ``r_tip / sin ψ``.

The effective tip diameter is calibrated on a reference sphere of calibrated diameter
``D_cal``: ``d_tip = 2 R_fit − D_cal`` (Sepahi Boroujeni (2021), Ch. 6: five points at
B = C = 0 give 5.925 mm on the Ø 19.05 mm precision sphere).  It absorbs the probe's
pre-travel, so it is smaller than the nominal 6 mm ball.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mtmetrology.fitting.elements import Circle, Cone, Cylinder, Element, Line, Plane, Sphere
from mtmetrology.fitting.least_squares import FitError, FitResult, fit_sphere
from mtmetrology.units import from_internal

__all__ = [
    "TipCalibration",
    "compensate",
    "compensate_points",
    "effective_tip_diameter",
    "surface_normals",
]


def _tip_radius(tip_radius: float) -> float:
    r = float(tip_radius)
    if not math.isfinite(r) or r < 0.0:
        raise FitError(f"tip_radius must be a finite length >= 0 mm, got {tip_radius!r}")
    return r


def compensate(element: Element, tip_radius: float, inside: bool = False) -> Element:
    """The surface element from the element fitted to stylus-centre points.

    Parameters
    ----------
    element : Sphere, Circle, Cylinder, Cone or Plane
        Element fitted to stylus-centre points (mm).
    tip_radius : float, mm
        Effective stylus-tip radius (half the calibrated effective diameter).
    inside : bool
        False for an outer feature (ball, shaft, male cone; for a plane: the material
        lies behind its normal), True for an inner feature (bore, ring, female cone; for
        a plane: the normal points into the material).

    Returns
    -------
    Element
        The same kind of element, offset by ``tip_radius`` towards the material.

    Raises
    ------
    FitError
        A negative tip radius, a tip not smaller than an outer feature's radius, or an
        element without a surface normal (a line).

    Examples
    --------
    >>> compensate(Sphere([0, 0, 0], 12.4875), 5.925 / 2).radius * 2
    19.05
    """
    r = _tip_radius(tip_radius)
    sign = 1.0 if inside else -1.0  # radius change for inner / outer features
    if isinstance(element, Sphere | Circle | Cylinder):
        radius = element.radius + sign * r
        if radius <= 0.0:
            raise FitError(
                f"tip radius {r} mm is not smaller than the fitted radius {element.radius:.6f} "
                f"mm of the stylus-centre {type(element).__name__.lower()}"
            )
        if isinstance(element, Sphere):
            return Sphere(element.centre, radius)
        if isinstance(element, Circle):
            return Circle(element.centre, radius, element.normal)
        return Cylinder(element.point, element.direction, radius)
    if isinstance(element, Cone):
        # Offsetting the surface by −sign·r along its normal slides the apex along the axis.
        shift = -sign * r / math.sin(element.half_angle)
        return Cone(element.apex + shift * element.direction, element.direction, element.half_angle)
    if isinstance(element, Plane):
        return Plane(element.point + sign * r * element.normal, element.normal)
    raise FitError(f"no probe compensation for a {type(element).__name__}")


def surface_normals(element: Element, points: object) -> np.ndarray:
    """Unit normals of ``element`` at the feet of ``points``, towards positive distance.

    Parameters
    ----------
    element : Sphere, Circle, Cylinder, Cone, Plane or 2-D Line
    points : (..., dim) array, mm

    Returns
    -------
    (..., dim) array
        Outward normals (away from the centre or axis; the plane or 2-D line normal).
    """
    p = np.asarray(points, dtype=float)
    if isinstance(element, Plane) or (isinstance(element, Line) and element.dim == 2):
        return np.broadcast_to(element.normal, p.shape).copy()
    if isinstance(element, Sphere):
        v = p - element.centre
    elif isinstance(element, Circle):
        v = p - element.centre
        if element.normal is not None:
            v = v - (v @ element.normal)[..., None] * element.normal
    elif isinstance(element, Cylinder | Cone):
        origin = element.point if isinstance(element, Cylinder) else element.apex
        v = p - origin
        v = v - (v @ element.direction)[..., None] * element.direction
    else:
        raise FitError(f"a {type(element).__name__} of dimension {element.dim} has no normal")
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    if np.any(norm == 0.0):
        raise FitError("a point lies on the centre or axis: its normal is undefined")
    u = v / norm
    if isinstance(element, Cone):
        psi = element.half_angle
        return math.cos(psi) * u - math.sin(psi) * element.direction
    return u


def compensate_points(
    points: object, element: Element, tip_radius: float, inside: bool = False
) -> np.ndarray:
    """Contact points from stylus-centre points, offset along the fitted element's normals.

    Parameters
    ----------
    points : (..., dim) array, mm
        Stylus-centre points.
    element : Element
        The element fitted to them (its normals give the offset directions).
    tip_radius : float, mm
    inside : bool
        As in :func:`compensate`: False when the probe is on the positive-distance side
        (outer feature), True when it is on the negative side (bore, ring).

    Returns
    -------
    (..., dim) array
        ``p − r_tip·n`` (outer) or ``p + r_tip·n`` (inner).
    """
    r = _tip_radius(tip_radius)
    p = np.asarray(points, dtype=float)
    return p + (1.0 if inside else -1.0) * r * surface_normals(element, p)


@dataclass(frozen=True)
class TipCalibration:
    """Effective stylus-tip diameter from a calibrated reference sphere.

    Attributes
    ----------
    diameter : float, mm
        ``d_tip = 2 R_fit − D_cal``.
    u : float, mm
        Standard uncertainty of ``d_tip``: ``u² = 4 u(R_fit)² + u(D_cal)²`` (0 when no
        uncertainties were given).
    fit : FitResult
        Least-squares sphere of the stylus-centre points.
    message : str
    """

    diameter: float
    u: float
    fit: FitResult
    message: str

    @property
    def radius(self) -> float:
        return self.diameter / 2.0


def effective_tip_diameter(
    points: object,
    calibrated_diameter: float,
    u_calibrated: float = 0.0,
    sigma_points: float | None = None,
) -> TipCalibration:
    """Calibrate the effective tip diameter on a reference sphere.

    Parameters
    ----------
    points : (n, 3) array, mm
        Stylus-centre points probed on the reference sphere (n ≥ 4, e.g. the five-point
        pattern at B = C = 0 of Sepahi Boroujeni (2021), Ch. 6).
    calibrated_diameter : float, mm
        Calibrated diameter ``D_cal`` of the sphere (19.05 mm in Sepahi Boroujeni (2021)).
    u_calibrated : float, mm
        Standard uncertainty of ``D_cal`` (Sepahi Boroujeni (2021): U = 0.5 µm, k = 2 → 0.25 µm).
    sigma_points : float, mm, optional
        Standard deviation of each probed coordinate (probing repeatability); gives
        ``u(R_fit)`` through the fit's parameter covariance.

    Returns
    -------
    TipCalibration

    Raises
    ------
    FitError
        Degenerate points (see :func:`fit_sphere`).
    FitError
        Non-positive calibrated diameter, negative uncertainties, or a fitted sphere
        smaller than the calibrated one (the points cannot be stylus centres outside it).

    Notes
    -----
    ``d_tip = 2 R_fit − D_cal`` (Sepahi Boroujeni (2021), Ch. 6: 5.925 mm).  The GUM
    law of propagation for uncorrelated R_fit and D_cal gives
    ``u²(d_tip) = 2² u²(R_fit) + u²(D_cal)`` (JCGM 100:2008, 5.1.2).
    """
    d_cal = float(calibrated_diameter)
    if not math.isfinite(d_cal) or d_cal <= 0:
        raise FitError(
            f"calibrated_diameter must be a positive length, got {calibrated_diameter!r}"
        )
    u_cal = float(u_calibrated)
    if not math.isfinite(u_cal) or u_cal < 0:
        raise FitError(f"u_calibrated must be >= 0 mm, got {u_calibrated!r}")
    fit = fit_sphere(points)
    diameter = 2.0 * fit.element.radius - d_cal
    if diameter <= 0:
        raise FitError(
            f"the fitted sphere (Ø {2 * fit.element.radius:.6f} mm) is not larger than the "
            f"calibrated sphere (Ø {d_cal} mm): these are not stylus-centre points outside it"
        )
    u_r = 0.0
    if sigma_points is not None:
        sigma = float(sigma_points)
        if not math.isfinite(sigma) or sigma < 0:
            raise FitError(f"sigma_points must be >= 0 mm, got {sigma_points!r}")
        u_r = math.sqrt(fit.parameter_covariance(sigma)[3, 3])
    u = math.sqrt(4.0 * u_r**2 + u_cal**2)
    message = (
        f"effective tip diameter {diameter:.4f} mm (u = {from_internal(u, 'µm'):.3f} µm) "
        f"from {fit.residuals.size} points on the Ø {d_cal} mm sphere, sphericity "
        f"{from_internal(fit.form_error, 'µm'):.3f} µm"
    )
    return TipCalibration(diameter=diameter, u=u, fit=fit, message=message)
