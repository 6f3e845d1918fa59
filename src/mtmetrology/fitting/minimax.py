"""Minimax (Chebyshev-norm, L∞) radial elements by sequential linear programming.

"Chebyshev" here is the norm (the largest absolute deviation is minimised), not the
Chebyshev polynomials of the error-motion bases (:mod:`mtmetrology.kinematics.basis`).
Roundness, sphericity, cylindricity, the spatial straightness cylinder, and the maximum
inscribed / minimum circumscribed circle, sphere and cylinder, solved from the
least-squares element as described in :mod:`mtmetrology.fitting.minimum_zone` (which
re-exports the public functions of this module).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog

from mtmetrology.fitting.elements import Circle, Cylinder, Plane, Sphere
from mtmetrology.fitting.geometry import plane_basis, point_set_size, principal_axes
from mtmetrology.fitting.least_squares import FitError, fit_circle, fit_cylinder, fit_sphere
from mtmetrology.fitting.validation import check_normal, check_points, require_spread
from mtmetrology.fitting.zones import (
    CONTACT_RTOL,
    Kind,
    ZoneResult,
    ZoneStatus,
    contact_indices,
)

# Linear programmes a sequential-LP zone fit may solve before it stops (status 0).
_MAX_ITERATIONS = 200

__all__ = [
    "circumscribed_circle",
    "circumscribed_cylinder",
    "circumscribed_sphere",
    "cylindricity",
    "inscribed_circle",
    "inscribed_cylinder",
    "inscribed_sphere",
    "roundness",
    "sphericity",
]

# --------------------------------------------------------------------------------------
# sequential linear programming on radial distances


class _CentreModel:
    """Distances of the points from a centre: circles (2-D) and spheres (3-D).

    ``d_i = |p_i - c|``, ``dd_i/dc = -(p_i - c)/d_i``; the step is the centre shift, mm.
    """

    def __init__(self, p: np.ndarray, centre: np.ndarray):
        self.p = p
        self.centre = np.asarray(centre, dtype=float)
        self.scales = np.ones(p.shape[1])

    def evaluate(self) -> tuple[np.ndarray, np.ndarray]:
        diff = self.p - self.centre  # (n, dim)
        d = np.linalg.norm(diff, axis=1)
        return d, -diff / np.maximum(d, np.finfo(float).tiny)[:, None]

    def moved(self, step: np.ndarray) -> _CentreModel:
        return _CentreModel(self.p, self.centre + step)


class AxisModel:
    """Distances of the points from an axis: cylinders and 3-D straightness.

    In a frame whose z-axis is the current axis, through the axial mean of the points, the
    axis moved by (a, b) at z = 0 and tilted by (alpha, beta) per unit z gives, to first
    order, ``d_i = rho_i - (x_i a + y_i b + z_i (x_i alpha + y_i beta)) / rho_i``
    (Forbes, NPL DITC 140/89, section 5). Tilts are scaled by the half-length of the point
    set so that every step component is a displacement in mm.

    Parameters
    ----------
    p : (n, 3) ndarray, mm
        The points.
    point : (3,) ndarray, mm
        A point of the axis.
    direction : (3,) ndarray
        The axis direction (any length).
    """

    def __init__(self, p: np.ndarray, point: np.ndarray, direction: np.ndarray):
        direction = np.asarray(direction, dtype=float)
        direction = direction / np.linalg.norm(direction)
        self.p = p
        self.frame = plane_basis(direction)  # rows e1, e2, axis
        local = (p - point) @ self.frame.T  # (n, 3)
        z_mean = local[:, 2].mean()
        self.point = np.asarray(point, dtype=float) + z_mean * direction
        self.direction = direction
        local[:, 2] -= z_mean
        self.local = local
        half_length = float(np.max(np.abs(local[:, 2])))
        half_length = half_length if half_length > 0.0 else 1.0
        self.scales = np.array([1.0, 1.0, 1.0 / half_length, 1.0 / half_length])

    def evaluate(self) -> tuple[np.ndarray, np.ndarray]:
        """Distances ρ (n,) of the points from the axis, mm, and their Jacobian (n, 4) with
        respect to the scaled step (a, b, α, β)."""
        x, y, z = self.local.T
        rho = np.hypot(x, y)
        inv = 1.0 / np.maximum(rho, np.finfo(float).tiny)
        jac = -np.stack([x, y, x * z, y * z], axis=1) * inv[:, None]  # (n, 4)
        return rho, jac

    def moved(self, step: np.ndarray) -> AxisModel:
        """The axis after the step (a, b, α, β): shifted by (a, b) and tilted by (α, β)."""
        e1, e2, axis = self.frame
        point = self.point + step[0] * e1 + step[1] * e2
        return AxisModel(self.p, point, axis + step[2] * e1 + step[3] * e2)


def _objective(d: np.ndarray, kind: Kind) -> float:
    """The minimised quantity: zone width, largest distance, or minus the smallest one."""
    if kind == "zone":
        return float(d.max() - d.min())
    if kind == "outer":
        return float(d.max())
    return float(-d.min())


def _lp_step(
    d: np.ndarray, jac: np.ndarray, scales: np.ndarray, radius: float, kind: Kind, floor: float
) -> tuple[np.ndarray, float] | None:
    """Solve the linearised Chebyshev problem in a box trust region of half-width ``radius``.

    Rows are shifted by the mid-range and divided by the range ``w`` of the distances, so
    HiGHS works on numbers of order one whatever the radius and the form error; the step
    variable ``v`` is the parameter step divided by ``scales * w``. Returns the parameter
    step and the predicted objective, or None when the LP solver fails.
    """
    ref = 0.5 * (d.max() + d.min())
    w = max(float(d.max() - d.min()), floor)
    dn = (d - ref) / w  # (n,)
    a = jac * scales  # (n, k)
    n, k = a.shape
    ones = np.ones((n, 1))
    zeros = np.zeros((n, 1))
    if kind == "zone":  # x = [v, l, h]
        cost = np.r_[np.zeros(k), -1.0, 1.0]
        a_ub = np.block([[a, zeros, -ones], [-a, ones, zeros]])
        b_ub = np.r_[-dn, dn]
    elif kind == "outer":  # x = [v, h]
        cost = np.r_[np.zeros(k), 1.0]
        a_ub = np.hstack([a, -ones])
        b_ub = -dn
    else:  # x = [v, l]
        cost = np.r_[np.zeros(k), -1.0]
        a_ub = np.hstack([-a, ones])
        b_ub = dn
    n_extra = len(cost) - k
    bounds = [(-radius / w, radius / w)] * k + [(None, None)] * n_extra
    res = linprog(cost, A_ub=a_ub, b_ub=b_ub, bounds=bounds, method="highs-ds")
    if res.status != 0:
        return None
    v, extra = res.x[:k], res.x[k:]
    if kind == "zone":
        predicted = w * (extra[1] - extra[0])
    elif kind == "outer":
        predicted = ref + w * extra[0]
    else:
        predicted = -(ref + w * extra[0])
    return scales * w * v, float(predicted)


@dataclass(frozen=True)
class LPSolution:
    """Where :func:`sequential_lp` stopped: the model (centre or axis) reached, its
    distances (n,) mm, the linear programmes solved and the :class:`ZoneStatus`."""

    model: _CentreModel | AxisModel
    distances: np.ndarray
    iterations: int
    status: ZoneStatus


def sequential_lp(model, kind: Kind, size: float, what: str) -> LPSolution:
    """Trust-region sequential LP for a Chebyshev problem on radial distances.

    A step is accepted when the true objective falls by at least 0.1 % of the decrease the
    linear model predicted; the region doubles after a good step that reached its edge and
    shrinks to a quarter of the step after a poor one. The iteration stops when the LP
    predicts no decrease above ``1e-13 * size`` (first-order Chebyshev optimality), or when
    the region has shrunk below the rounding level of the coordinates.

    Parameters
    ----------
    model : AxisModel or the centre model of this module
        The starting element (the least-squares one): ``evaluate()`` gives the distances
        and their Jacobian, ``moved(step)`` the element after a step, ``scales`` the step
        scales.
    kind : {"zone", "outer", "inner"}
        Minimise the zone width ``max d − min d``, ``max d`` (circumscribed) or
        ``−min d`` (inscribed).
    size : float
        The point-set size, mm (:func:`mtmetrology.fitting.geometry.point_set_size`).
    what : str
        The element in words, for the messages.

    Returns
    -------
    LPSolution

    Raises
    ------
    FitError
        When the element runs off to infinity. An inscribed element whose centre lies
        inside the points' hull has a radius below the hull's diameter, ``2 * size``;
        beyond it the points do not surround the element (an arc, a partial surface).
        A zone whose radius exceeds ``1e3 * size`` is tending to a straight line or a
        plane: the points do not determine a centre.
    """
    limit = 2.0 * size if kind == "inner" else 1e3 * size
    d, jac = model.evaluate()
    f = _objective(d, kind)
    floor = 1e-9 * size
    radius = max(float(d.max() - d.min()), floor)
    tol = 1e-13 * size
    for iteration in range(1, _MAX_ITERATIONS + 1):
        lp = _lp_step(d, jac, model.scales, radius, kind, floor)
        if lp is None:
            return LPSolution(model, d, iteration, ZoneStatus.LP_FAILED)
        step, predicted = lp
        decrease = f - predicted
        if decrease <= tol:
            return LPSolution(model, d, iteration, ZoneStatus.OPTIMAL)
        trial = model.moved(step)
        d_trial, jac_trial = trial.evaluate()
        f_trial = _objective(d_trial, kind)
        ratio = (f - f_trial) / decrease
        reach = float(np.max(np.abs(step / model.scales)))
        if ratio > 1e-3:
            model, d, jac, f = trial, d_trial, jac_trial, f_trial
            if d.min() > limit:
                raise FitError(
                    f"the {what} is unbounded: its radius grows without limit because the "
                    "points do not surround a centre or axis (a partial arc or surface?)"
                )
            if ratio > 0.75 and reach >= 0.99 * radius:
                radius *= 2.0
        else:
            radius = 0.25 * reach
            if radius <= 1e-15 * size:
                small = decrease <= 1e-9 * max(float(d.max() - d.min()), floor)
                status = ZoneStatus.ROUNDING_LEVEL if small else ZoneStatus.TRUST_REGION_LIMIT
                return LPSolution(model, d, iteration, status)
    return LPSolution(model, d, _MAX_ITERATIONS, ZoneStatus.ITERATION_LIMIT)


def _radial_result(
    solution: LPSolution,
    kind: Kind,
    size: float,
    least_squares_form_error: float,
    make_element,
    what: str,
) -> ZoneResult:
    """Zone result for circles, spheres and cylinders from the radial distances."""
    d = solution.distances
    low, high = float(d.min()), float(d.max())
    tol = CONTACT_RTOL * size
    if kind == "zone":
        radius = 0.5 * (low + high)
        contacts = np.union1d(contact_indices(d, low, tol), contact_indices(d, high, tol))
        method = "minimum-zone"
    elif kind == "outer":
        radius = high
        contacts = contact_indices(d, high, tol)
        method = "circumscribed"
    else:
        radius = low
        contacts = contact_indices(d, low, tol)
        method = "inscribed"
        if radius <= tol:
            raise FitError(f"the {what} is degenerate: a point lies on its centre or axis")
    return ZoneResult(
        element=make_element(radius),
        method=method,
        form_error=high - low,
        bounds=(low, high),
        residuals=d - radius,
        contacts=contacts,
        least_squares_form_error=least_squares_form_error,
        iterations=solution.iterations,
        status=solution.status,
    )


def _circle(points, normal, kind: Kind, what: str) -> ZoneResult:
    p = check_points(points, what, (2, 3), 3)
    if p.shape[1] == 2 and normal is not None:
        raise FitError("normal applies to points in 3-D; 2-D points lie in their plane")
    centroid, s, _ = principal_axes(p)
    require_spread(what, s, len(p), 2, "collinear")
    if p.shape[1] == 2:
        least_squares = fit_circle(p).element
        basis = np.eye(2)
    else:
        # The least-squares circle in the given plane, or in its own least-squares plane.
        plane = None if normal is None else Plane(centroid, check_normal(normal))
        least_squares = fit_circle(p, plane=plane).element
        basis = plane_basis(least_squares.normal)[:2]  # rows u, v spanning the plane
    uv = (p - centroid) @ basis.T  # (n, 2) in-plane coordinates
    require_spread(what, np.linalg.svd(uv, compute_uv=False), len(uv), 2, "collinear in the plane")
    model = _CentreModel(uv, (least_squares.centre - centroid) @ basis.T)
    d0, _ = model.evaluate()
    size = point_set_size(p)
    solution = sequential_lp(model, kind, size, what)

    def make_element(radius: float) -> Circle:
        centre = centroid + solution.model.centre @ basis
        return Circle(centre, radius, least_squares.normal)

    return _radial_result(solution, kind, size, float(np.ptp(d0)), make_element, what)


def _sphere(points, kind: Kind, what: str) -> ZoneResult:
    p = check_points(points, what, (3,), 4)
    centroid, s, _ = principal_axes(p)
    require_spread(what, s, len(p), 3, "coplanar")
    start = fit_sphere(p).element.centre
    size = point_set_size(p)
    model = _CentreModel(p - centroid, start - centroid)
    d0, _ = model.evaluate()
    solution = sequential_lp(model, kind, size, what)

    def make_element(radius: float) -> Sphere:
        return Sphere(centroid + solution.model.centre, radius)

    return _radial_result(solution, kind, size, float(np.ptp(d0)), make_element, what)


def _cylinder(points, kind: Kind, what: str) -> ZoneResult:
    p = check_points(points, what, (3,), 5)
    centroid, s, _ = principal_axes(p)
    require_spread(what, s, len(p), 2, "collinear")
    start = fit_cylinder(p).element
    size = point_set_size(p)
    model = AxisModel(p - centroid, start.point - centroid, start.direction)
    d0, _ = model.evaluate()
    solution = sequential_lp(model, kind, size, what)

    def make_element(radius: float) -> Cylinder:
        return Cylinder(centroid + solution.model.point, solution.model.direction, radius)

    return _radial_result(solution, kind, size, float(np.ptp(d0)), make_element, what)


def roundness(points, *, normal=None) -> ZoneResult:
    """Minimum-zone roundness: the two concentric circles of least radial separation.

    Parameters
    ----------
    points : (n, 2) or (n, 3) array_like, mm
        Points of the profile, n >= 3, not collinear.
    normal : (3,) array_like, optional
        For 3-D points, the normal of the plane of the profile: the points are projected
        on that plane (ISO 12181-1 roundness in a cross-section). Default: the normal of
        the least-squares circle.

    Returns
    -------
    ZoneResult
        ``element`` is the mean circle of the zone, ``bounds`` the (inner, outer) radii and
        ``form_error`` their difference, the roundness.

    Raises
    ------
    FitError
        Wrong shape, a non-finite coordinate, fewer than 3 points, collinear points.

    Notes
    -----
    Minimise ``max_i r_i(c) - min_i r_i(c)`` over the centre ``c``, ``r_i = |p_i - c|``
    (ISO 12181-1:2011, 3.3.1, MZCI), by sequential LP from the least-squares centre. At a
    regular solution four points alternate between the outer and inner circles.

    Examples
    --------
    >>> t = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    >>> r = 10 + 0.002 * (np.arange(12) % 2 - 0.5)
    >>> round(roundness(np.c_[r * np.cos(t), r * np.sin(t)]).form_error, 12)
    0.002
    """
    return _circle(points, normal, "zone", "roundness")


def inscribed_circle(points, *, normal=None) -> ZoneResult:
    """Maximum inscribed circle of the points of a bore or ring.

    Parameters
    ----------
    points : (n, 2) or (n, 3) array_like, mm
        Points of the profile, n >= 3, not collinear, surrounding the centre.
    normal : (3,) array_like, optional
        For 3-D points, the normal of the plane of the profile (default: that of the
        least-squares circle).

    Returns
    -------
    ZoneResult
        ``element`` is the inscribed circle; ``bounds`` are (its radius, the largest
        radius of a point about its centre); ``form_error`` is their difference.

    Raises
    ------
    FitError
        Wrong shape, a non-finite coordinate, fewer than 3 points, collinear points.

    Notes
    -----
    Maximise ``min_i |p_i - c|`` over ``c`` (ISO 12181-1:2011, 3.3.3, MICI) by sequential
    LP from the least-squares centre: the local maximum nearest to it, which is the
    largest empty circle centred inside the points when they surround the centre.
    """
    return _circle(points, normal, "inner", "inscribed circle")


def circumscribed_circle(points, *, normal=None) -> ZoneResult:
    """Minimum circumscribed circle of the points of a shaft or disc.

    Parameters
    ----------
    points : (n, 2) or (n, 3) array_like, mm
        Points of the profile, n >= 3, not collinear.
    normal : (3,) array_like, optional
        For 3-D points, the normal of the plane of the profile (default: that of the
        least-squares circle).

    Returns
    -------
    ZoneResult
        ``element`` is the circumscribed circle; ``bounds`` are (the smallest radius of a
        point about its centre, its radius); ``form_error`` is their difference.

    Raises
    ------
    FitError
        Wrong shape, a non-finite coordinate, fewer than 3 points, collinear points.

    Notes
    -----
    Minimise ``max_i |p_i - c|`` over ``c`` (ISO 12181-1:2011, 3.3.2, MCCI). The function
    is convex, so the sequential LP reaches the global minimum, the smallest enclosing
    circle, defined by two or three points.
    """
    return _circle(points, normal, "outer", "circumscribed circle")


def sphericity(points) -> ZoneResult:
    """Minimum-zone sphericity: the two concentric spheres of least radial separation.

    Parameters
    ----------
    points : (n, 3) array_like, mm
        Points of the sphere, n >= 4, not coplanar.

    Returns
    -------
    ZoneResult
        ``element`` is the mean sphere of the zone, ``bounds`` the (inner, outer) radii,
        ``form_error`` their difference.

    Raises
    ------
    FitError
        Wrong shape, a non-finite coordinate, fewer than 4 points, coplanar points.

    Notes
    -----
    Minimise ``max_i |p_i - c| - min_i |p_i - c|`` over the centre ``c`` by sequential LP
    from the least-squares centre; five points alternate at a regular solution.
    """
    return _sphere(points, "zone", "sphericity")


def inscribed_sphere(points) -> ZoneResult:
    """Maximum inscribed sphere of the points of a spherical cavity.

    Parameters
    ----------
    points : (n, 3) array_like, mm
        Points of the cavity, n >= 4, not coplanar, surrounding the centre.

    Returns
    -------
    ZoneResult
        ``element`` is the inscribed sphere; ``bounds`` (its radius, the largest radius of
        a point about its centre).

    Raises
    ------
    FitError
        Wrong shape, a non-finite coordinate, fewer than 4 points, coplanar points.

    Notes
    -----
    Maximise ``min_i |p_i - c|`` over ``c`` by sequential LP from the least-squares
    centre (the local maximum nearest to it).
    """
    return _sphere(points, "inner", "inscribed sphere")


def circumscribed_sphere(points) -> ZoneResult:
    """Minimum circumscribed sphere of the points of a ball.

    Parameters
    ----------
    points : (n, 3) array_like, mm
        Points of the ball, n >= 4, not coplanar.

    Returns
    -------
    ZoneResult
        ``element`` is the circumscribed sphere; ``bounds`` (the smallest radius of a point
        about its centre, its radius).

    Raises
    ------
    FitError
        Wrong shape, a non-finite coordinate, fewer than 4 points, coplanar points.

    Notes
    -----
    Minimise ``max_i |p_i - c|`` over ``c``: convex, so the global minimum, the smallest
    enclosing sphere, defined by two to four points.
    """
    return _sphere(points, "outer", "circumscribed sphere")


def cylindricity(points) -> ZoneResult:
    """Minimum-zone cylindricity: two coaxial cylinders of least radial separation.

    Parameters
    ----------
    points : (n, 3) array_like, mm
        Points of the cylinder, n >= 5, not collinear.

    Returns
    -------
    ZoneResult
        ``element`` is the mean cylinder of the zone, ``bounds`` the (inner, outer) radii,
        ``form_error`` their difference.

    Raises
    ------
    FitError
        Wrong shape, a non-finite coordinate, fewer than 5 points, collinear points, or a
        failed least-squares cylinder.

    Notes
    -----
    Minimise ``max_i rho_i - min_i rho_i`` over the axis (four parameters), ``rho_i`` the
    distance of ``p_i`` from the axis (ISO 12180-1:2011, 3.3.1, MZCY), by sequential LP
    from the least-squares cylinder; six points alternate at a regular solution.
    """
    return _cylinder(points, "zone", "cylindricity")


def inscribed_cylinder(points) -> ZoneResult:
    """Maximum inscribed cylinder of the points of a bore.

    Parameters
    ----------
    points : (n, 3) array_like, mm
        Points of the bore, n >= 5, not collinear.

    Returns
    -------
    ZoneResult
        ``element`` is the inscribed cylinder; ``bounds`` (its radius, the largest distance
        of a point from its axis).

    Raises
    ------
    FitError
        Wrong shape, a non-finite coordinate, fewer than 5 points, collinear points, or a
        failed least-squares cylinder.

    Notes
    -----
    Maximise ``min_i rho_i`` over the axis by sequential LP from the least-squares
    cylinder (ISO 12180-1:2011, 3.3.3, MICY): the local maximum nearest to it.
    """
    return _cylinder(points, "inner", "inscribed cylinder")


def circumscribed_cylinder(points) -> ZoneResult:
    """Minimum circumscribed cylinder of the points of a shaft.

    Parameters
    ----------
    points : (n, 3) array_like, mm
        Points of the shaft, n >= 5, not collinear.

    Returns
    -------
    ZoneResult
        ``element`` is the circumscribed cylinder; ``bounds`` (the smallest distance of a
        point from its axis, its radius).

    Raises
    ------
    FitError
        Wrong shape, a non-finite coordinate, fewer than 5 points, collinear points, or a
        failed least-squares cylinder.

    Notes
    -----
    Minimise ``max_i rho_i`` over the axis by sequential LP from the least-squares
    cylinder (ISO 12180-1:2011, 3.3.2, MCCY); not convex in the axis direction, so the
    local minimum nearest the least-squares axis.
    """
    return _cylinder(points, "outer", "circumscribed cylinder")
