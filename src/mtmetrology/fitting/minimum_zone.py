"""Minimum-zone (Chebyshev), maximum-inscribed and minimum-circumscribed elements.

Form tolerances are defined by zones: flatness is the distance between the two closest
parallel planes that contain every point, roundness the radial separation of the two closest
concentric circles, and so on (ISO 1101; ISO 12780/12781/12181/12180 for the straightness,
flatness, roundness and cylindricity filters of the Chebyshev reference). The least-squares
peak-to-valley is an upper bound of the minimum-zone value; the minimum zone is what a
tolerance is checked against.

Algorithms
----------
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

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from mtmetrology.fitting.elements import Line, Plane
from mtmetrology.fitting.geometry import plane_basis, point_set_size, principal_axes
from mtmetrology.fitting.least_squares import FitError, fit_line, fit_plane
from mtmetrology.fitting.minimax import (
    AxisModel,
    circumscribed_circle,
    circumscribed_cylinder,
    circumscribed_sphere,
    cylindricity,
    inscribed_circle,
    inscribed_cylinder,
    inscribed_sphere,
    roundness,
    sequential_lp,
    sphericity,
)
from mtmetrology.fitting.validation import check_normal, check_points, require_spread
from mtmetrology.fitting.zones import (
    CONTACT_RTOL,
    ZONE_STATUS_MESSAGES,
    ZoneResult,
    ZoneStatus,
    contact_indices,
)

__all__ = [
    "ZONE_STATUS_MESSAGES",
    "ZoneResult",
    "ZoneStatus",
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
    centroid, s, vt = principal_axes(p)
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
    centroid, s, vt = principal_axes(p)
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


def _parallel_zone(element, residuals, width, size, least_squares_pv) -> ZoneResult:
    """Result of an exact zone between two parallel lines or planes."""
    half = 0.5 * width
    tol = CONTACT_RTOL * size
    return ZoneResult(
        element=element,
        method="minimum-zone",
        form_error=width,
        bounds=(-half, half),
        residuals=residuals,
        contacts=np.union1d(
            contact_indices(residuals, -half, tol), contact_indices(residuals, half, tol)
        ),
        least_squares_form_error=least_squares_pv,
        iterations=0,
        status=ZoneStatus.EXACT,
    )


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
    p = check_points(points, "straightness", (2, 3), 2)
    centroid, s, _ = principal_axes(p)
    require_spread("straightness", s, len(p), 1, "coincident")
    if p.shape[1] == 3 and plane_normal is None:
        start = fit_line(p).element
        size = point_set_size(p)
        model = AxisModel(p - centroid, start.point - centroid, start.direction)
        d0, _ = model.evaluate()
        solution = sequential_lp(model, "outer", size, "straightness")
        d = solution.distances
        radius = float(d.max())
        return ZoneResult(
            element=Line(centroid + solution.model.point, solution.model.direction),
            method="minimum-zone",
            form_error=2.0 * radius,
            bounds=(0.0, radius),
            residuals=d,
            contacts=contact_indices(d, radius, CONTACT_RTOL * size),
            least_squares_form_error=2.0 * float(d0.max()),
            iterations=solution.iterations,
            status=solution.status,
        )
    if p.shape[1] == 2:
        if plane_normal is not None:
            raise FitError("plane_normal applies to points in 3-D; 2-D points lie in their plane")
        basis = np.eye(2)
    else:
        basis = plane_basis(check_normal(plane_normal))[:2]
    uv = (p - centroid) @ basis.T  # (n, 2)
    require_spread("straightness", np.linalg.svd(uv, compute_uv=False), len(uv), 1, "coincident")
    least_squares = fit_line(uv).element
    n, low, high = _min_width_2d(uv)
    if n @ least_squares.normal < 0.0:  # same orientation as the least-squares line
        n, low, high = -n, -high, -low
    mid = 0.5 * (low + high)
    return _parallel_zone(
        Line(centroid + (mid * n) @ basis, np.array([n[1], -n[0]]) @ basis),
        uv @ n - mid,
        high - low,
        point_set_size(p),
        float(np.ptp(least_squares.distances(uv))),
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
    p = check_points(points, "flatness", (3,), 3)
    centroid, s, _ = principal_axes(p)
    require_spread("flatness", s, len(p), 2, "collinear")
    least_squares = fit_plane(p).element
    q = p - centroid  # (n, 3)
    n, low, high = _min_width_3d(q)
    if n @ least_squares.normal < 0.0:
        n, low, high = -n, -high, -low
    mid = 0.5 * (low + high)
    return _parallel_zone(
        Plane(centroid + mid * n, n),
        q @ n - mid,
        high - low,
        point_set_size(p),
        float(np.ptp(least_squares.distances(p))),
    )
