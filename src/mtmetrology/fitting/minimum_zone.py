"""Minimum-zone (Chebyshev), maximum-inscribed and minimum-circumscribed elements.

Form tolerances are defined by zones: flatness is the distance between the two closest
parallel planes that contain every point, roundness the radial separation of the two closest
concentric circles, and so on (ISO 1101; ISO 12780/12781/12181/12180 for the straightness,
flatness, roundness and cylindricity filters of the Chebyshev reference). The least-squares
peak-to-valley is an upper bound of the minimum-zone value; the minimum zone is what a
tolerance is checked against.

Methods
-------
Flatness and straightness are solved *exactly* with the convex hull, since a zone of two
parallel planes (lines) contains the points if and only if it contains their hull:

* 2-D straightness: the minimum width of a convex polygon is attained with one zone line
  through a hull edge (rotating calipers, Toussaint 1983), so it is the smallest, over hull
  edges, of the largest distance of a hull vertex from that edge.
* flatness: the minimum width of a convex polyhedron is attained either by a face and a
  vertex or by two antipodal edges (Houle & Toussaint 1988). Every face is tried; every pair
  of edges whose normal cones admit the common normal is tried. The hull is computed on
  points whitened by their principal axes (an affine map keeps the hull's combinatorics),
  so a plate 1 µm thin and 500 mm wide is as well conditioned for Qhull as a cube.

Roundness, sphericity, cylindricity, 3-D straightness (the smallest cylinder that contains
the points, ISO 12780-1) and the inscribed / circumscribed elements are solved by sequential
linear programming from the least-squares element: the radial distances are linearised about
the current element, the linear Chebyshev problem

    minimise  h - l   subject to  l <= d_i + J_i delta <= h,  |delta_j| <= Delta s_j

(or minimise ``h`` with only the upper constraints for a circumscribed element, maximise
``l`` with only the lower ones for an inscribed element) is solved with HiGHS dual simplex,
and the step is accepted or the trust region ``Delta`` shrunk by the ratio of the actual to
the predicted decrease (Fletcher's SL1QP idea in its l-infinity form; Anthony, Anthony,
Bittner et al., "Reference software for finding Chebyshev best-fit geometric elements",
Precision Engineering 19 (1996) 28-36). Near a vertex solution the iteration is Newton's
method on the active set and converges quadratically. Minimum circumscribed circles and
spheres are convex problems, so their solution is the global one; the zone, inscribed and
cylinder problems are not convex, and the iteration returns the local minimax element
nearest the least-squares start, which is the wanted one for the small form errors of
measured features.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from scipy.optimize import linprog
from scipy.spatial import ConvexHull, QhullError

from mtmetrology.fitting.elements import Circle, Cylinder, Line, Plane, Sphere
from mtmetrology.fitting.least_squares import (
    FitError,
    fit_circle,
    fit_cylinder,
    fit_line,
    fit_plane,
    fit_sphere,
)

__all__ = [
    "ZoneResult",
    "circumscribed_circle",
    "circumscribed_cylinder",
    "circumscribed_sphere",
    "cylindricity",
    "flatness",
    "inscribed_circle",
    "inscribed_cylinder",
    "inscribed_sphere",
    "roundness",
    "sphericity",
    "straightness",
]

Kind = Literal["zone", "outer", "inner"]

# Contacts are the points within this fraction of the point-set size of a zone boundary:
# far below any form error a CMM resolves, far above the rounding of the distances.
_CONTACT_RTOL = 1e-9
_MAX_ITERATIONS = 200


@dataclass(frozen=True)
class ZoneResult:
    """A Chebyshev-type reference element and the zone it defines.

    Attributes
    ----------
    element : Line, Plane, Circle, Sphere or Cylinder
        The reference element: the mid-zone element for a minimum zone (mid plane, mean
        circle of the two concentric circles, ...), the axis of the smallest enclosing
        cylinder for a 3-D straightness, and the inscribed or circumscribed element itself.
    method : {"minimum-zone", "inscribed", "circumscribed"}
        What was solved.
    form_error : float
        Zone width, mm: the distance between the two planes or lines, the radial separation
        of the two circles, spheres or cylinders; the diameter of the smallest enclosing
        cylinder for a 3-D straightness; for an inscribed or circumscribed element the
        radial range of the points about it.
    bounds : tuple of float
        The two zone boundaries, mm: (inner, outer) radii for circles, spheres and
        cylinders; signed offsets (-t/2, t/2) of the two parallel lines or planes from the
        mid element; (0, radius) of the enclosing cylinder for a 3-D straightness.
    residuals : (n,) ndarray
        Deviations of the points from ``element``, mm (signed normal distances; radial
        distances from the axis for a 3-D straightness).
    contacts : (m,) ndarray of int
        Indices of the points on the zone boundaries: those that define the zone.
    least_squares_form_error : float
        Peak-to-valley of the residuals of the least-squares element the iteration
        started from, mm (same definition as ``form_error``), for comparison.
    iterations : int
        Linear programmes solved (0 for the exact hull methods).
    converged : bool
        Whether the stopping test was met.
    message : str
        What happened, in words.
    """

    element: Line | Plane | Circle | Sphere | Cylinder
    method: str
    form_error: float
    bounds: tuple[float, float]
    residuals: np.ndarray = field(repr=False)
    contacts: np.ndarray
    least_squares_form_error: float
    iterations: int
    converged: bool
    message: str


# --------------------------------------------------------------------------------------
# input checks


def _check_points(points, dims: tuple[int, ...], min_points: int, what: str) -> np.ndarray:
    """Points as a float (n, dim) array, refused with a clear message when unusable."""
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] not in dims:
        shapes = " or ".join(f"(n, {d})" for d in dims)
        raise FitError(f"points for {what} must be an array of shape {shapes}, got {p.shape}")
    if not np.all(np.isfinite(p)):
        bad = int(np.flatnonzero(~np.all(np.isfinite(p), axis=1))[0])
        raise FitError(f"points for {what}: point {bad} is not finite (NaN or infinite)")
    if len(p) < min_points:
        raise FitError(f"{what} needs at least {min_points} points, got {len(p)}")
    return p


def _principal_axes(p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centroid, singular values and principal directions (rows) of a point set."""
    centroid = p.mean(axis=0)
    _, s, vt = np.linalg.svd(p - centroid, full_matrices=False)
    return centroid, s, vt


def _require_spread(s: np.ndarray, rank: int, what: str, degenerate: str) -> None:
    """Refuse a point set whose centred coordinates have rank below ``rank``."""
    if s[0] == 0.0 or s[rank - 1] <= 1e-10 * s[0]:
        raise FitError(f"{what} is undefined: the points are {degenerate}")


def _check_normal(normal) -> np.ndarray:
    n = np.asarray(normal, dtype=float)
    if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) == 0.0:
        raise FitError(f"normal must be a finite, non-zero 3-vector, got {normal!r}")
    return n / np.linalg.norm(n)


def _plane_basis(normal: np.ndarray) -> np.ndarray:
    """Rows u, v, n: a right-handed orthonormal frame whose third axis is ``normal``."""
    helper = np.eye(3)[int(np.argmin(np.abs(normal)))]
    u = np.cross(normal, helper)
    u /= np.linalg.norm(u)
    return np.stack([u, np.cross(normal, u), normal])


def _contacts(values: np.ndarray, level: float, tol: float) -> np.ndarray:
    return np.flatnonzero(np.abs(values - level) <= tol)


def _size(p: np.ndarray) -> float:
    """Radius of the point set about its centroid: the scale of its coordinates."""
    return float(np.max(np.linalg.norm(p - p.mean(axis=0), axis=1)))


# --------------------------------------------------------------------------------------
# exact hull methods: 2-D straightness and flatness


def _whitened_hull(p: np.ndarray, centroid, s, vt) -> ConvexHull:
    """Convex hull of the points mapped onto their principal axes and scaled to unit spread.

    The map is affine, so the hull's vertices, edges and faces are those of the hull of
    ``p``; only the conditioning changes.
    """
    return ConvexHull((p - centroid) @ vt.T / s)


def _min_width_2d(p: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Unit normal ``n`` and the extreme offsets (low, high) of ``p @ n`` of least width.

    ``p`` : (n, 2). Rotating calipers: the optimal zone has a line through a hull edge.
    """
    centroid, s, vt = _principal_axes(p)
    if s[1] <= 1e-13 * s[0]:
        # Collinear to rounding: the zone is the principal direction, width at rounding level.
        n = vt[1]
        h = p @ n
        return n, float(h.min()), float(h.max())
    hull = _whitened_hull(p, centroid, s, vt)
    v = p[hull.vertices]  # (h, 2), counter-clockwise
    edges = np.roll(v, -1, axis=0) - v  # (h, 2)
    normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    heights = normals @ v.T  # (edges, vertices)
    widths = heights.max(axis=1) - heights.min(axis=1)
    best = int(np.argmin(widths))
    n = normals[best]
    h = p @ n
    return n, float(h.min()), float(h.max())


def _min_width_3d(p: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Unit normal ``n`` and the extreme offsets of ``p @ n`` of least width, ``p`` (n, 3).

    Candidates are the hull's face normals and the common normals of antipodal edge pairs
    (Houle & Toussaint 1988); every candidate's width is measured over all hull vertices,
    so a candidate admitted by rounding can only be too wide, never too narrow.
    """
    centroid, s, vt = _principal_axes(p)
    if s[2] <= 1e-13 * s[0]:
        n = vt[2]
        h = p @ n
        return n, float(h.min()), float(h.max())
    try:
        hull = _whitened_hull(p, centroid, s, vt)
    except QhullError:
        # Qhull calls the whitened set flat only when it is flat to rounding.
        n = vt[2]
        h = p @ n
        return n, float(h.min()), float(h.max())
    q = p - centroid  # (n, 3), centred to keep the products small
    tri = hull.simplices  # (f, 3)
    a, b, c = q[tri[:, 0]], q[tri[:, 1]], q[tri[:, 2]]
    face_n = np.cross(b - a, c - a)
    face_n /= np.linalg.norm(face_n, axis=1, keepdims=True)
    face_n *= np.where(np.einsum("ij,ij->i", face_n, a) < 0.0, -1.0, 1.0)[:, None]  # outward
    verts = q[hull.vertices]  # (h, 3)

    candidates = [face_n]
    # Edges with their two adjacent faces: the edge opposite vertex k of face f is shared
    # with hull.neighbors[f, k]; keep each edge once.
    f_idx = np.repeat(np.arange(len(tri)), 3)
    k_idx = np.tile(np.arange(3), len(tri))
    g_idx = hull.neighbors[f_idx, k_idx]
    once = f_idx < g_idx
    f_idx, k_idx, g_idx = f_idx[once], k_idx[once], g_idx[once]
    e0 = tri[f_idx, (k_idx + 1) % 3]
    e1 = tri[f_idx, (k_idx + 2) % 3]
    n_a, n_b = face_n[f_idx], face_n[g_idx]
    # Edges between coplanar triangles of a triangulated facet are not edges of the hull.
    real = np.linalg.norm(np.cross(n_a, n_b), axis=1) > 1e-12
    e0, e1, n_a, n_b = e0[real], e1[real], n_a[real], n_b[real]
    direction = q[e1] - q[e0]
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    # Orient each edge so that its normal cone runs counter-clockwise from n_a to n_b.
    flip = np.einsum("ij,ij->i", np.cross(n_a, n_b), direction) < 0.0
    direction[flip] *= -1.0

    def in_cone(m, e, na, nb):
        # m (.., 3) perpendicular to e; inside the cone spanned by na and nb.
        return (np.einsum("...j,...j->...", np.cross(na, m), e) >= -1e-12) & (
            np.einsum("...j,...j->...", np.cross(m, nb), e) >= -1e-12
        )

    # Gauss-map prefilter: the normal cone of an edge is an arc of the unit sphere with
    # midpoint mu and half-angle theta; two edges can be antipodal only if the arc of one
    # meets the reflected arc of the other, which needs angle(mu1, -mu2) <= theta1 + theta2.
    mu = n_a + n_b
    mu /= np.linalg.norm(mu, axis=1, keepdims=True)
    cos_h = np.clip(np.einsum("ij,ij->i", mu, n_a), -1.0, 1.0)
    sin_h = np.sqrt(1.0 - cos_h**2)
    n_edges = len(direction)
    chunk = max(1, 4_000_000 // max(n_edges, 1))
    for i0 in range(0, n_edges, chunk):
        rows = slice(i0, min(i0 + chunk, n_edges))
        reach = np.outer(cos_h[rows], cos_h) - np.outer(sin_h[rows], sin_h)  # cos(th1 + th2)
        i, j = np.nonzero(-(mu[rows] @ mu.T) >= reach - 1e-9)  # (c, E) -> pairs
        i += i0
        m = np.cross(direction[i], direction[j])  # (pairs, 3) common normals
        norm = np.linalg.norm(m, axis=1)
        parallel = norm < 1e-12
        m /= np.where(parallel, 1.0, norm)[:, None]
        cone1 = in_cone(m, direction[i], n_a[i], n_b[i])
        m[~cone1] *= -1.0  # the sign whose direction is in the first edge's cone
        cone1 |= in_cone(m, direction[i], n_a[i], n_b[i])
        keep = cone1 & in_cone(-m, direction[j], n_a[j], n_b[j]) & ~parallel
        candidates.append(m[keep])
    normals = np.concatenate(candidates)  # (k, 3)
    best_width, best_n = np.inf, face_n[0]
    for j0 in range(0, len(normals), 4096):
        heights = normals[j0 : j0 + 4096] @ verts.T  # (k, h)
        widths = heights.max(axis=1) - heights.min(axis=1)
        j = int(np.argmin(widths))
        if widths[j] < best_width:
            best_width, best_n = float(widths[j]), normals[j0 + j]
    h = p @ best_n
    return best_n, float(h.min()), float(h.max())


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


class _AxisModel:
    """Distances of the points from an axis: cylinders and 3-D straightness.

    In a frame whose z-axis is the current axis, through the axial mean of the points, the
    axis moved by (a, b) at z = 0 and tilted by (alpha, beta) per unit z gives, to first
    order, ``d_i = rho_i - (x_i a + y_i b + z_i (x_i alpha + y_i beta)) / rho_i``
    (Forbes, NPL DITC 140/89, section 5). Tilts are scaled by the half-length of the point
    set so that every step component is a displacement in mm.
    """

    def __init__(self, p: np.ndarray, point: np.ndarray, direction: np.ndarray):
        direction = np.asarray(direction, dtype=float)
        direction = direction / np.linalg.norm(direction)
        self.p = p
        self.frame = _plane_basis(direction)  # rows e1, e2, axis
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
        x, y, z = self.local.T
        rho = np.hypot(x, y)
        inv = 1.0 / np.maximum(rho, np.finfo(float).tiny)
        jac = -np.stack([x, y, x * z, y * z], axis=1) * inv[:, None]  # (n, 4)
        return rho, jac

    def moved(self, step: np.ndarray) -> _AxisModel:
        e1, e2, axis = self.frame
        point = self.point + step[0] * e1 + step[1] * e2
        return _AxisModel(self.p, point, axis + step[2] * e1 + step[3] * e2)


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
class _Solution:
    model: _CentreModel | _AxisModel
    distances: np.ndarray
    iterations: int
    converged: bool
    message: str


def _count(iterations: int) -> str:
    return f"{iterations} linear programme{'' if iterations == 1 else 's'}"


def _sequential_lp(model, kind: Kind, size: float, what: str) -> _Solution:
    """Trust-region sequential LP for a Chebyshev problem on radial distances.

    A step is accepted when the true objective falls by at least 0.1 % of the decrease the
    linear model predicted; the region doubles after a good step that reached its edge and
    shrinks to a quarter of the step after a poor one. The iteration stops when the LP
    predicts no decrease above ``1e-13 * size`` (first-order Chebyshev optimality), or when
    the region has shrunk below the rounding level of the coordinates.

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
            return _Solution(model, d, iteration, False, "the linear programme failed (HiGHS)")
        step, predicted = lp
        decrease = f - predicted
        if decrease <= tol:
            return _Solution(model, d, iteration, True, f"converged: {_count(iteration)}")
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
                return _Solution(
                    model,
                    d,
                    iteration,
                    decrease <= 1e-9 * max(float(d.max() - d.min()), floor),
                    f"stopped after {_count(iteration)}: the trust region fell "
                    f"below the rounding level with {decrease:.3g} mm of predicted decrease",
                )
    return _Solution(
        model, d, _MAX_ITERATIONS, False, f"no convergence in {_MAX_ITERATIONS} linear programmes"
    )


# --------------------------------------------------------------------------------------
# public functions


def _radial_result(
    solution: _Solution,
    kind: Kind,
    size: float,
    least_squares_form_error: float,
    make_element,
    what: str,
) -> ZoneResult:
    """Zone result for circles, spheres and cylinders from the radial distances."""
    d = solution.distances
    low, high = float(d.min()), float(d.max())
    tol = _CONTACT_RTOL * size
    if kind == "zone":
        radius = 0.5 * (low + high)
        contacts = np.union1d(_contacts(d, low, tol), _contacts(d, high, tol))
        method = "minimum-zone"
    elif kind == "outer":
        radius = high
        contacts = _contacts(d, high, tol)
        method = "circumscribed"
    else:
        radius = low
        contacts = _contacts(d, low, tol)
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
        converged=solution.converged,
        message=solution.message,
    )


def _circle(points, normal, kind: Kind, what: str) -> ZoneResult:
    p = _check_points(points, (2, 3), 3, what)
    if p.shape[1] == 2 and normal is not None:
        raise FitError("normal applies to points in 3-D; 2-D points lie in their plane")
    centroid, s, _ = _principal_axes(p)
    _require_spread(s, 2, what, "collinear")
    if p.shape[1] == 2:
        least_squares = fit_circle(p).element
        basis = np.eye(2)
    else:
        # The least-squares circle in the given plane, or in its own least-squares plane.
        plane = None if normal is None else Plane(centroid, _check_normal(normal))
        least_squares = fit_circle(p, plane=plane).element
        basis = _plane_basis(least_squares.normal)[:2]  # rows u, v spanning the plane
    uv = (p - centroid) @ basis.T  # (n, 2) in-plane coordinates
    _require_spread(np.linalg.svd(uv, compute_uv=False), 2, what, "collinear in the plane")
    model = _CentreModel(uv, (least_squares.centre - centroid) @ basis.T)
    d0, _ = model.evaluate()
    size = _size(p)
    solution = _sequential_lp(model, kind, size, what)

    def make_element(radius: float) -> Circle:
        centre = centroid + solution.model.centre @ basis
        return Circle(centre, radius, least_squares.normal)

    return _radial_result(solution, kind, size, float(np.ptp(d0)), make_element, what)


def _sphere(points, kind: Kind, what: str) -> ZoneResult:
    p = _check_points(points, (3,), 4, what)
    centroid, s, _ = _principal_axes(p)
    _require_spread(s, 3, what, "coplanar")
    start = fit_sphere(p).element.centre
    size = _size(p)
    model = _CentreModel(p - centroid, start - centroid)
    d0, _ = model.evaluate()
    solution = _sequential_lp(model, kind, size, what)

    def make_element(radius: float) -> Sphere:
        return Sphere(centroid + solution.model.centre, radius)

    return _radial_result(solution, kind, size, float(np.ptp(d0)), make_element, what)


def _cylinder(points, kind: Kind, what: str) -> ZoneResult:
    p = _check_points(points, (3,), 5, what)
    centroid, s, _ = _principal_axes(p)
    _require_spread(s, 2, what, "collinear")
    start = fit_cylinder(p).element
    size = _size(p)
    model = _AxisModel(p - centroid, start.point - centroid, start.direction)
    d0, _ = model.evaluate()
    solution = _sequential_lp(model, kind, size, what)

    def make_element(radius: float) -> Cylinder:
        return Cylinder(centroid + solution.model.point, solution.model.direction, radius)

    return _radial_result(solution, kind, size, float(np.ptp(d0)), make_element, what)


def straightness(points, *, plane_normal=None) -> ZoneResult:
    """Minimum-zone straightness of a line in a plane or in space.

    Parameters
    ----------
    points : (n, 2) or (n, 3) array_like, mm
        Points of the profile, n >= 2.
    plane_normal : (3,) array_like, optional
        For 3-D points of a profile in a plane (ISO 12780 straightness of a line in a
        surface): the normal of that plane; the points are projected on it and the 2-D
        zone is computed. Without it, 3-D points get the spatial straightness.

    Returns
    -------
    ZoneResult
        In 2-D (or with ``plane_normal``), ``element`` is the mid line of the two closest
        parallel lines containing the points and ``form_error`` their distance. In 3-D,
        ``element`` is the axis of the smallest cylinder containing the points and
        ``form_error`` its diameter; ``residuals`` are distances from that axis.

    Raises
    ------
    FitError
        Wrong shape, a non-finite coordinate, fewer than 2 points, all points coincident.

    Notes
    -----
    The 2-D zone is exact: the narrowest strip containing a convex polygon has one side
    through a polygon edge (rotating calipers; Toussaint, Proc. IEEE MELECON 1983). The
    spatial straightness is the minimum circumscribed cylinder (ISO 12780-1:2011, 3.3.2,
    MZCY for a line in space), solved by sequential LP from the least-squares line.

    Examples
    --------
    >>> round(straightness([[0, 0], [1, 0.002], [2, 0], [3, 0.002]]).form_error, 12)
    0.002
    """
    p = _check_points(points, (2, 3), 2, "straightness")
    centroid, s, _ = _principal_axes(p)
    _require_spread(s, 1, "straightness", "coincident")
    if p.shape[1] == 3 and plane_normal is None:
        start = fit_line(p).element
        size = _size(p)
        model = _AxisModel(p - centroid, start.point - centroid, start.direction)
        d0, _ = model.evaluate()
        solution = _sequential_lp(model, "outer", size, "straightness")
        d = solution.distances
        radius = float(d.max())
        return ZoneResult(
            element=Line(centroid + solution.model.point, solution.model.direction),
            method="minimum-zone",
            form_error=2.0 * radius,
            bounds=(0.0, radius),
            residuals=d,
            contacts=_contacts(d, radius, _CONTACT_RTOL * size),
            least_squares_form_error=2.0 * float(d0.max()),
            iterations=solution.iterations,
            converged=solution.converged,
            message=solution.message,
        )
    if p.shape[1] == 2:
        if plane_normal is not None:
            raise FitError("plane_normal applies to points in 3-D; 2-D points lie in their plane")
        basis = np.eye(2)
    else:
        basis = _plane_basis(_check_normal(plane_normal))[:2]
    uv = (p - centroid) @ basis.T  # (n, 2)
    _require_spread(np.linalg.svd(uv, compute_uv=False), 1, "straightness", "coincident")
    least_squares = fit_line(uv).element
    n, low, high = _min_width_2d(uv)
    if n @ least_squares.normal < 0.0:  # same orientation as the least-squares line
        n, low, high = -n, -high, -low
    mid = 0.5 * (low + high)
    residuals = uv @ n - mid
    half = 0.5 * (high - low)
    tol = _CONTACT_RTOL * _size(p)
    return ZoneResult(
        element=Line(centroid + (mid * n) @ basis, np.array([n[1], -n[0]]) @ basis),
        method="minimum-zone",
        form_error=high - low,
        bounds=(-half, half),
        residuals=residuals,
        contacts=np.union1d(_contacts(residuals, -half, tol), _contacts(residuals, half, tol)),
        least_squares_form_error=float(np.ptp(least_squares.distances(uv))),
        iterations=0,
        converged=True,
        message="exact: minimum width of the convex hull (rotating calipers)",
    )


def flatness(points) -> ZoneResult:
    """Minimum-zone flatness: the two closest parallel planes that contain the points.

    Parameters
    ----------
    points : (n, 3) array_like, mm
        Points of the surface, n >= 3, not all collinear.

    Returns
    -------
    ZoneResult
        ``element`` is the mid plane (normal oriented as the least-squares plane's),
        ``form_error`` the distance between the two planes, ``bounds`` (-t/2, t/2),
        ``contacts`` the points on either plane (at least four unless the set is planar).

    Raises
    ------
    FitError
        Wrong shape, a non-finite coordinate, fewer than 3 points, collinear points.

    Notes
    -----
    Exact: the width of a point set in direction ``n`` is that of its convex hull, and the
    minimum width of a convex polyhedron is attained with one plane on a face and the other
    through a vertex, or with the two planes through two antipodal edges (Houle and
    Toussaint, IEEE PAMI 10 (1988) 761-765; ISO 12781-1:2011, 3.3.1 minimum zone
    reference planes, MZPL).

    Examples
    --------
    >>> pts = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, 0.5, 0.003]]
    >>> round(flatness(pts).form_error, 12)
    0.003
    """
    p = _check_points(points, (3,), 3, "flatness")
    centroid, s, _ = _principal_axes(p)
    _require_spread(s, 2, "flatness", "collinear")
    least_squares = fit_plane(p).element
    q = p - centroid  # (n, 3)
    n, low, high = _min_width_3d(q)
    if n @ least_squares.normal < 0.0:
        n, low, high = -n, -high, -low
    mid = 0.5 * (low + high)
    residuals = q @ n - mid
    half = 0.5 * (high - low)
    tol = _CONTACT_RTOL * _size(p)
    return ZoneResult(
        element=Plane(centroid + mid * n, n),
        method="minimum-zone",
        form_error=high - low,
        bounds=(-half, half),
        residuals=residuals,
        contacts=np.union1d(_contacts(residuals, -half, tol), _contacts(residuals, half, tol)),
        least_squares_form_error=float(np.ptp(least_squares.distances(p))),
        iterations=0,
        converged=True,
        message="exact: minimum width of the convex hull (faces and antipodal edge pairs)",
    )


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
