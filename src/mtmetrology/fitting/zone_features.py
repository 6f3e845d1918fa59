"""Minimum-zone (Chebyshev) features for the uncertainty engine.

The form tolerances of ISO 1101 are zones: flatness is the distance between the two
closest parallel planes containing the points (ISO 12781-1:2011, MZPL), roundness the
radial separation of the two closest concentric circles (ISO 12181-1:2011, MZCI),
cylindricity and sphericity that of two coaxial cylinders (ISO 12180-1:2011, MZCY) and
two concentric spheres.  The least-squares form errors of
:mod:`mtmetrology.fitting.features` are upper bounds of these values.  The features
here follow the same protocol (Sepahi Boroujeni (2021), Ch. 6: a feature is a function
of the 3n point coordinates; :class:`mtmetrology.fitting.features.Feature`):

* ``value(points)``, points ``(..., n, 3)``: every feature here solves all sets together
  by the batched exchange algorithm of :mod:`mtmetrology.fitting.batch_zones` (10⁵ sets
  of 25 points in seconds; the few sets it cannot settle go to the per-set solver of
  :mod:`mtmetrology.fitting.minimum_zone`).  A set that the per-set solver did not solve
  raises :class:`mtmetrology.errors.ConvergenceError`.
* ``jacobian(points)``, one set ``(n, 3)``: the exact derivative of the zone at its
  solution, ``(1, 3n)``.

Jacobian at a vertex solution
-----------------------------
With the element's parameters θ (p of them: centre, axis or normal) and the zone
boundaries l ≤ h, the minimum zone solves ``min h − l`` subject to
``l ≤ d_i(θ, q_i) ≤ h``.  At a regular (vertex) solution exactly p + 2 points touch the
boundaries, ``d_i = h`` for the outer contacts O and ``d_i = l`` for the inner
contacts I, and these p + 2 equations determine ``z = (θ, l, h)`` as a smooth function
of the points (implicit-function theorem).  With ``M = ∂F/∂z`` of that square system
and the output ``g = eᵀz`` (``e`` = (0, −1, 1) for the width h − l, (0, 1, 1) for the
mid-zone diameter l + h),

    ∂g/∂q_k = −Σ_{i ∈ O ∪ I} y_i ∂d_i/∂q_k,     Mᵀ y = e,

which is the LP dual: for the width, ``λ_i = −y_i`` (i ∈ O) and ``μ_i = y_i`` (i ∈ I) are the
multipliers of the active constraints, ``Σ λ = Σ μ = 1``, and
``∂W/∂q = Σ_O λ_i ∂d_i/∂q − Σ_I μ_i ∂d_i/∂q``.  This is exact — not a linearisation —
wherever the contact set is unique and non-degenerate (p + 2 contacts, M regular),
which is the case for almost every measured point set; it holds for perturbations
that keep the contact set.  (Roundness adds the motion of the least-squares
projection plane, to second order in the form deviations.)  At a degenerate set (zero
form error, symmetric nominal points, more or fewer than p + 2 contacts) the zone is
not differentiable and ``jacobian`` raises
:class:`mtmetrology.errors.RankDeficientError`: use the Monte Carlo method (JCGM 101:2008) there.

References
----------
ISO 1101:2017, *Geometrical product specifications (GPS) — Geometrical tolerancing —
Tolerances of form, orientation, location and run-out*.
ISO 12180-1:2011 (cylindricity), ISO 12181-1:2011 (roundness), ISO 12781-1:2011
(flatness), *Geometrical product specifications (GPS)*, Part 1: Vocabulary and
parameters.
ISO 14405-1:2016, *Geometrical product specifications (GPS) — Dimensional tolerancing —
Part 1: Linear sizes* (the minimax size, modifier GC).
Anthony, G. T., Anthony, H. M., Bittner, B., et al. (1996). Reference software for
finding Chebyshev best-fit geometric elements. *Precision Engineering* 19, 28–36.
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, Ch. 6.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from mtmetrology.errors import ConvergenceError, RankDeficientError
from mtmetrology.fitting.batch_zones import BatchZoneFit
from mtmetrology.fitting.features import (
    ScalarFeature,
    TipCompensatedSize,
    single_point_set,
    stacked_point_sets,
)
from mtmetrology.fitting.geometry import plane_basis
from mtmetrology.fitting.least_squares import fit_plane
from mtmetrology.fitting.zones import ZoneResult

__all__ = [
    "MinimumZoneCylinderDiameter",
    "MinimumZoneCylindricity",
    "MinimumZoneFlatness",
    "MinimumZoneRoundness",
    "MinimumZoneSphereDiameter",
    "MinimumZoneSphericity",
]

WIDTH = (-1.0, 1.0)  # e for the zone width h − l
MEAN_DIAMETER = (1.0, 1.0)  # e for the mid-zone diameter l + h

# Gradients of the contact distances: (∂d/∂θ (m, p), ∂d_i/∂q_i (m, 3), and the
# dependence of every d_i on all points through the projection plane (m, n, 3) or None).
Gradients = tuple[np.ndarray, np.ndarray, np.ndarray | None]


def _sphere_gradients(p: np.ndarray, zone: ZoneResult, idx: np.ndarray) -> Gradients:
    """θ = centre: ``d_i = ‖q_i − c‖``, ``∂d/∂c = −u_i``, ``∂d_i/∂q_i = u_i``."""
    w = p[idx] - zone.element.centre
    u = w / np.linalg.norm(w, axis=1, keepdims=True)
    return -u, u, None


def _cylinder_gradients(p: np.ndarray, zone: ZoneResult, idx: np.ndarray) -> Gradients:
    """θ = (shift, tilt) of the axis in its frame (e1, e2, a): with local coordinates
    (x, y, z) of q_i, ``ρ = ‖(x, y)‖`` and ``∂ρ/∂θ = −(x, y, xz, yz)/ρ`` (Forbes, NPL
    DITC 140/89, §4.8); ``∂ρ_i/∂q_i`` is the radial unit vector."""
    e1, e2, a = plane_basis(zone.element.direction)
    w = p[idx] - zone.element.point
    x, y, z = w @ e1, w @ e2, w @ a
    rho = np.hypot(x, y)
    grad = -np.column_stack([x, y, x * z, y * z]) / rho[:, None]
    return grad, (x[:, None] * e1 + y[:, None] * e2) / rho[:, None], None


def _flatness_gradients(p: np.ndarray, zone: ZoneResult, idx: np.ndarray) -> Gradients:
    """θ = tilt of the normal, n ≈ n0 + θ1 e1 + θ2 e2: ``d_i = n·(q_i − c)``,
    ``∂d/∂θ = ((q_i − c)·e1, (q_i − c)·e2)``, ``∂d_i/∂q_i = n``."""
    e1, e2, nrm = plane_basis(zone.element.normal)
    w = p[idx] - zone.element.point
    return np.column_stack([w @ e1, w @ e2]), np.broadcast_to(nrm, w.shape), None


def _circle_gradients(p: np.ndarray, zone: ZoneResult, idx: np.ndarray) -> Gradients:
    """θ = in-plane centre shift; ``d_i = ‖w_i − (w_i·n) n‖``, ``w_i = q_i − c``.

    The plane is the least-squares plane of all the points, so every d_i also moves with
    every point through the normal: ``∂d_i/∂n = −(w_i·n) w_i / d_i`` times ``∂n/∂q`` of
    :func:`fit_plane`.  That term is of the order of (height off the plane / radius), and
    the plane's first-order Jacobian is accurate to O(flatness / size) relative, so its
    error is second order in the form deviations.
    """
    e1, e2, nrm = plane_basis(zone.element.normal)
    w = p[idx] - zone.element.centre
    height = w @ nrm
    flat = w - height[:, None] * nrm
    d = np.linalg.norm(flat, axis=1)
    radial = flat / d[:, None]
    dn_dq = fit_plane(p).parameter_jacobian[3:6]  # (3, n, 3)
    d_dn = -(height / d)[:, None] * w  # (m, 3)
    return -np.column_stack([radial @ e1, radial @ e2]), radial, d_dn @ dn_dq.reshape(3, -1)


def _zone_jacobian(
    p: np.ndarray, zone: ZoneResult, gradients: Callable, e: tuple[float, float], name: str
) -> np.ndarray:
    """``∂(eᵀ(l, h))/∂q`` (1, 3n) from the active system of the zone (module notes)."""
    idx = np.asarray(zone.contacts)
    grad_theta, direct, through_plane = gradients(p, zone, idx)
    n_par = grad_theta.shape[1]
    if idx.size != n_par + 2:
        raise RankDeficientError(
            f"{name}: the minimum zone touches {idx.size} points where a differentiable "
            f"(vertex) zone touches {n_par + 2} (zero form error or symmetric points?); "
            "the zone has no derivative here: use the Monte Carlo method"
        )
    outer = zone.residuals[idx] > 0.0
    m = np.zeros((idx.size, n_par + 2))
    m[:, :n_par] = grad_theta
    m[~outer, n_par] = -1.0  # d_i − l = 0
    m[outer, n_par + 1] = -1.0  # d_i − h = 0
    if np.linalg.cond(m) > 1e12:
        raise RankDeficientError(
            f"{name}: the contact points of the minimum zone do not determine it "
            "(singular active set); use the Monte Carlo method"
        )
    y = np.linalg.solve(m.T, np.r_[np.zeros(n_par), e])
    jac = np.zeros_like(p)
    jac[idx] = -y[:, None] * direct
    out = jac.reshape(1, -1)
    if through_plane is not None:
        out = out - (y @ through_plane)[None, :]
    return out


def _zones(stack: np.ndarray, solve: Callable, name: str) -> list[ZoneResult]:
    """One minimax fit per set (the loop for a shape without a batched solver)."""
    zones = []
    for k, points in enumerate(stack):
        zone = solve(points)
        if not zone.success:
            raise ConvergenceError(f"{name}: set {k}: {zone.message}")
        zones.append(zone)
    return zones


@dataclass(frozen=True)
class _ZoneShape:
    """What differs between the zone features: the solver, gradients, minimum points."""

    solver: str  # the function of mtmetrology.fitting.minimum_zone
    gradients: Callable
    min_points: int
    batched: str | None = None  # the function of mtmetrology.fitting.batch_zones, if any

    def solve(self, points: np.ndarray) -> ZoneResult:
        # Imported on first use: the linear programmes and hulls (scipy.optimize,
        # scipy.spatial) cost a least-squares process about 20 MiB it never needs.
        from mtmetrology.fitting import minimum_zone

        return getattr(minimum_zone, self.solver)(points)

    def solve_sets(self, stack: np.ndarray, name: str) -> BatchZoneFit | list[ZoneResult]:
        """All sets (K, n, 3): batched where a batched solver exists, else a loop."""
        if self.batched is None:
            return _zones(stack, self.solve, name)
        from mtmetrology.fitting import batch_zones

        return getattr(batch_zones, self.batched)(stack)


_SPHERE = _ZoneShape("sphericity", _sphere_gradients, 5, "minimum_zone_sphericity")
_CIRCLE = _ZoneShape("roundness", _circle_gradients, 4, "minimum_zone_roundness")
_CYLINDER = _ZoneShape("cylindricity", _cylinder_gradients, 6, "minimum_zone_cylindricity")
_PLANE = _ZoneShape("flatness", _flatness_gradients, 4, "minimum_zone_flatness")


class _ZoneFeature:
    """Value and Jacobian of one quantity of the minimum zone; subclasses set the
    element's ``_shape``, the ``_quantity`` (:data:`WIDTH` or :data:`MEAN_DIAMETER`) and
    how a zone gives the value (``_of``)."""

    _shape: ClassVar[_ZoneShape]
    _quantity: ClassVar[tuple[float, float]]
    name: str

    @property
    def min_points(self) -> int:
        """p + 2: the contacts of a regular zone of an element of p parameters."""
        return self._shape.min_points

    def value(self, points: object) -> np.ndarray:
        stack, lead = stacked_point_sets(points, self.name, self.min_points)
        zones = self._shape.solve_sets(stack, self.name)
        if isinstance(zones, BatchZoneFit):
            return self._of_sets(zones).reshape(lead)
        return np.array([self._of(z) for z in zones]).reshape(lead)

    def jacobian(self, points: object) -> np.ndarray:
        p = single_point_set(points, self.name, self.min_points)
        shape = self._shape
        return _zone_jacobian(p, shape.solve(p), shape.gradients, self._quantity, self.name)


class _MinimumZoneForm(_ZoneFeature, ScalarFeature):
    """A zone width (the form error)."""

    _quantity = WIDTH

    def _of(self, zone: ZoneResult) -> float:
        return zone.form_error

    def _of_sets(self, zones: BatchZoneFit) -> np.ndarray:
        return zones.form_error


class _MinimumZoneDiameter(_ZoneFeature, TipCompensatedSize):
    """A mid-zone diameter ``r_in + r_out ± d_tip``."""

    _quantity = MEAN_DIAMETER

    def _of(self, zone: ZoneResult) -> float:
        return sum(zone.bounds) + self._offset()

    def _of_sets(self, zones: BatchZoneFit) -> np.ndarray:
        return zones.bounds.sum(axis=1) + self._offset()


@dataclass(frozen=True)
class MinimumZoneSphericity(_MinimumZoneForm):
    """Minimum-zone sphericity: radial separation of the two closest concentric spheres
    containing the points (ISO 1101 zone; :func:`mtmetrology.fitting.minimum_zone.sphericity`).

    ``W = min_c (max_i ‖q_i − c‖ − min_i ‖q_i − c‖)``; points ``(..., n, 3)``, n ≥ 5
    (a differentiable zone touches 5 points).  Cost and Jacobian: see the module notes.

    Examples
    --------
    >>> u = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
    >>> r = 10 + 0.001 * np.array([1, 1, -1, -1, 1, 1])
    >>> round(float(MinimumZoneSphericity().value(r[:, None] * u)), 12)
    0.002
    """

    _shape: ClassVar[_ZoneShape] = _SPHERE
    name: str = "minimum_zone_sphericity"
    unit: str = "mm"


@dataclass(frozen=True)
class MinimumZoneRoundness(_MinimumZoneForm):
    """Minimum-zone roundness of a probed cross-section (ISO 12181-1:2011, MZCI).

    The points ``(..., n, 3)``, n ≥ 4, are projected on their least-squares plane and
    ``W = min_c (max_i ρ_i − min_i ρ_i)`` over the in-plane centre c
    (:func:`mtmetrology.fitting.minimum_zone.roundness`).  The Jacobian includes the
    dependence of the projection plane on every point, to second order in the form
    deviations off the plane (exact for a planar profile).

    Examples
    --------
    >>> t = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    >>> r = 20 + 0.001 * (np.arange(12) % 2 - 0.5)
    >>> ring = np.c_[r * np.cos(t), r * np.sin(t), np.zeros(12)]
    >>> round(float(MinimumZoneRoundness().value(ring)), 12)
    0.001
    """

    _shape: ClassVar[_ZoneShape] = _CIRCLE
    name: str = "minimum_zone_roundness"
    unit: str = "mm"


@dataclass(frozen=True)
class MinimumZoneFlatness(_MinimumZoneForm):
    """Minimum-zone flatness: distance between the two closest parallel planes containing
    the points (ISO 12781-1:2011, MZPL), solved exactly on the convex hull
    (:func:`mtmetrology.fitting.minimum_zone.flatness`).

    Points ``(..., n, 3)``, n ≥ 4 (a differentiable zone touches 4 points: a face and a
    vertex of the hull, or two antipodal edges).

    Examples
    --------
    >>> pts = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, 0.5, 0.003]]
    >>> round(float(MinimumZoneFlatness().value(pts)), 12)
    0.003
    """

    _shape: ClassVar[_ZoneShape] = _PLANE
    name: str = "minimum_zone_flatness"
    unit: str = "mm"


@dataclass(frozen=True)
class MinimumZoneCylindricity(_MinimumZoneForm):
    """Minimum-zone cylindricity: radial separation of the two closest coaxial cylinders
    containing the points (ISO 12180-1:2011, MZCY;
    :func:`mtmetrology.fitting.minimum_zone.cylindricity`).

    Points ``(..., n, 3)``, n ≥ 6 (a differentiable zone touches 6 points).

    Examples
    --------
    >>> t = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    >>> r = 12 + 0.001 * np.cos(4 * t)
    >>> ring = np.c_[r * np.cos(t), r * np.sin(t), np.zeros(8)]
    >>> round(float(MinimumZoneCylindricity().value(np.r_[ring, ring + [0, 0, 15]])), 9)
    0.002
    """

    _shape: ClassVar[_ZoneShape] = _CYLINDER
    name: str = "minimum_zone_cylindricity"
    unit: str = "mm"


@dataclass(frozen=True)
class MinimumZoneSphereDiameter(_MinimumZoneDiameter):
    """Minimax (Chebyshev) sphere diameter with tip compensation: the diameter of the mean
    sphere of the minimum zone, ``D = (r_in + r_out) ∓ d_tip``.

    ``inner=False`` (a ball probed from outside): ``D = r_in + r_out − d_tip``;
    ``inner=True`` (a spherical cavity): ``+ d_tip``, as :class:`SphereDiameter`.

    Notes
    -----
    The minimax associated sphere is the mid-zone sphere of the minimum zone: ISO
    14405-1:2016 calls its diameter the minimax size (modifier GC).  It is well defined
    where the minimum zone is unique (a generic point set): the same contact points fix
    the centre, both radii and hence their mean.  ``value`` solves all sets together
    (:mod:`mtmetrology.fitting.batch_zones`); the
    Jacobian uses ``e = (1, 1)`` in the module's active-set formula.

    Examples
    --------
    >>> u = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
    >>> r = 12.4875 + 0.001 * np.array([1, 1, -1, -1, 1, 1])
    >>> round(float(MinimumZoneSphereDiameter(tip_diameter=5.925).value(r[:, None] * u)), 12)
    19.05
    """

    _shape: ClassVar[_ZoneShape] = _SPHERE
    tip_diameter: float = 0.0
    inner: bool = False
    name: str = "minimum_zone_sphere_diameter"
    unit: str = "mm"


@dataclass(frozen=True)
class MinimumZoneCylinderDiameter(_MinimumZoneDiameter):
    """Minimax (Chebyshev) cylinder diameter with tip compensation: the diameter of the
    mean cylinder of the minimum zone, ``D = (r_in + r_out) ± d_tip``.

    ``inner=True`` (a bore): ``+ d_tip``; ``inner=False`` (a shaft): ``− d_tip``, as
    :class:`CylinderDiameter`.  ISO 14405-1:2016 minimax size (GC); well defined where
    the minimum zone is unique (see :class:`MinimumZoneSphereDiameter`).  Points
    ``(..., n, 3)``, n ≥ 6.

    Examples
    --------
    >>> t = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    >>> r = 12 + 0.001 * np.cos(4 * t)
    >>> ring = np.c_[r * np.cos(t), r * np.sin(t), np.zeros(8)]
    >>> bore = np.r_[ring, ring + [0, 0, 15]]
    >>> round(float(MinimumZoneCylinderDiameter(tip_diameter=6.0).value(bore)), 9)
    30.0
    """

    _shape: ClassVar[_ZoneShape] = _CYLINDER
    inner: bool = True
    tip_diameter: float = 0.0
    name: str = "minimum_zone_cylinder_diameter"
    unit: str = "mm"
