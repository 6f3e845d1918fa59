"""Tests of mtmetrology.fitting.minimum_zone.

References used here are independent of the module: exhaustive enumeration of the
finitely many candidate zones (planes through point triples or edge pairs, circles through
2-3 points, concentric circles / spheres through 4 / 5 points), Voronoi vertices for the
largest empty circle, and a smooth constrained reformulation solved by SLSQP for the
cylinder problems.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize
from scipy.spatial import Delaunay, Voronoi
from scipy.spatial.transform import Rotation

from mtmetrology.fitting import minimax
from mtmetrology.fitting.elements import Circle, Cylinder, Line, Plane, Sphere
from mtmetrology.fitting.least_squares import (
    FitError,
    fit_circle,
    fit_cylinder,
    fit_line,
    fit_plane,
    fit_sphere,
)
from mtmetrology.fitting.minimum_zone import (
    ZONE_STATUS_MESSAGES,
    ZoneResult,
    ZoneStatus,
    circumscribed_circle,
    circumscribed_cylinder,
    circumscribed_sphere,
    cylindricity,
    flatness,
    inscribed_circle,
    inscribed_cylinder,
    inscribed_sphere,
    roundness,
    sphericity,
    straightness,
)
from mtmetrology.optimize import Status

# --------------------------------------------------------------------------------------
# data


def _rigid(rng, points, offset=100.0):
    """Points moved by a random rotation and a translation of about ``offset`` mm."""
    rot = Rotation.random(random_state=rng).as_matrix()
    return points @ rot.T + rng.uniform(-offset, offset, 3), rot


def _unit_vectors(rng, n):
    u = rng.normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1, keepdims=True)


def _ring(rng, n, radius, form):
    """(n, 2) points at random angles, radius perturbed uniformly by +-form/2."""
    angle = rng.uniform(0.0, 2.0 * np.pi, n)
    r = radius + form * rng.uniform(-0.5, 0.5, n)
    return np.c_[r * np.cos(angle), r * np.sin(angle)]


def _ball(rng, n, radius, form):
    return (radius + form * rng.uniform(-0.5, 0.5, (n, 1))) * _unit_vectors(rng, n)


def _shaft(rng, n, radius, length, form):
    """(n, 3) points about the z-axis, z in [-length/2, length/2]."""
    angle = rng.uniform(0.0, 2.0 * np.pi, n)
    r = radius + form * rng.uniform(-0.5, 0.5, n)
    return np.c_[r * np.cos(angle), r * np.sin(angle), rng.uniform(-0.5, 0.5, n) * length]


# --------------------------------------------------------------------------------------
# brute-force references


def _span(points, normals):
    """Width of the points along each unit normal, (k, d) -> (k,)."""
    h = normals @ points.T
    return h.max(axis=1) - h.min(axis=1)


def _flatness_exhaustive(p):
    """Minimum width over every plane through three points and every common normal of two
    point-pair directions: the candidates of the face-vertex and edge-edge cases."""
    normals = []
    for i, j, k in itertools.combinations(range(len(p)), 3):
        normals.append(np.cross(p[j] - p[i], p[k] - p[i]))
    pairs = [p[j] - p[i] for i, j in itertools.combinations(range(len(p)), 2)]
    for a, b in itertools.combinations(pairs, 2):
        normals.append(np.cross(a, b))
    normals = np.array(normals)
    norm = np.linalg.norm(normals, axis=1)
    normals = normals[norm > 1e-12] / norm[norm > 1e-12, None]
    return _span(p, normals).min()


def _straightness_exhaustive(p):
    d = np.array([p[j] - p[i] for i, j in itertools.combinations(range(len(p)), 2)])
    normals = np.c_[-d[:, 1], d[:, 0]] / np.linalg.norm(d, axis=1, keepdims=True)
    return _span(p, normals).min()


def _equidistant_centre(groups, dim):
    """Centre equidistant from the points within each group (linear equations), or None."""
    rows, rhs = [], []
    for g in groups:
        for q in g[1:]:
            rows.append(2.0 * (q - g[0]))
            rhs.append(q @ q - g[0] @ g[0])
    a, b = np.array(rows), np.array(rhs)
    if len(rows) != dim or abs(np.linalg.det(a)) < 1e-12:
        return None
    return np.linalg.solve(a, b)


def _zone_exhaustive(p, n_contacts):
    """Global minimum radial zone: the centre is equidistant from the outer contacts and
    from the inner contacts (n_contacts = dim + 2 points, at least one of each)."""
    dim = p.shape[1]
    best = np.inf
    for subset in itertools.combinations(range(len(p)), n_contacts):
        for k in range(1, n_contacts):
            for outer in itertools.combinations(subset, k):
                inner = [i for i in subset if i not in outer]
                c = _equidistant_centre([p[list(outer)], p[inner]], dim)
                if c is not None:
                    r = np.linalg.norm(p - c, axis=1)
                    best = min(best, r.max() - r.min())
    return best


def _enclosing_exhaustive(p):
    """Smallest enclosing circle / sphere from every set of 2 .. dim+1 points."""
    dim = p.shape[1]
    best = np.inf
    for m in range(2, dim + 2):
        for subset in itertools.combinations(range(len(p)), m):
            q = p[list(subset)]
            # Centre in the affine hull of the subset, equidistant from its points.
            basis = (q[1:] - q[0]).T  # (dim, m-1)
            gram = basis.T @ basis
            if abs(np.linalg.det(gram)) < 1e-12:
                continue
            coef = np.linalg.solve(gram, 0.5 * np.diag(gram))
            c = q[0] + basis @ coef
            r = np.linalg.norm(q[0] - c)
            if np.all(np.linalg.norm(p - c, axis=1) <= r + 1e-12):
                best = min(best, r)
    return best


def _largest_empty_circle(p):
    """Largest circle free of points with its centre inside the hull: a Voronoi vertex."""
    vertices = Voronoi(p).vertices
    vertices = vertices[Delaunay(p).find_simplex(vertices) >= 0]
    return max(np.linalg.norm(p - v, axis=1).min() for v in vertices)


def _axis_distances(p, x):
    """Distances from the axis through (x0, y0, 0) along (a, b, 1)."""
    direction = np.array([x[2], x[3], 1.0]) / np.hypot(1.0, np.hypot(x[2], x[3]))
    v = p - np.array([x[0], x[1], 0.0])
    return np.linalg.norm(v - (v @ direction)[:, None] * direction, axis=1)


def _axis_epigraph(p, kind):
    """SLSQP on the smooth epigraph form of the cylinder problems, axis near z.

    zone: min h - l s.t. l <= rho_i <= h; outer: min h s.t. rho_i <= h; inner: max l.
    """
    rho0 = _axis_distances(p, np.zeros(4))
    x0 = np.r_[np.zeros(4), rho0.min(), rho0.max()]
    cost = {"zone": lambda x: x[5] - x[4], "outer": lambda x: x[5], "inner": lambda x: -x[4]}
    cons = []
    if kind in ("zone", "inner"):
        cons.append({"type": "ineq", "fun": lambda x: _axis_distances(p, x[:4]) - x[4]})
    if kind in ("zone", "outer"):
        cons.append({"type": "ineq", "fun": lambda x: x[5] - _axis_distances(p, x[:4])})
    res = minimize(
        cost[kind], x0, method="SLSQP", constraints=cons, options={"ftol": 1e-15, "maxiter": 500}
    )
    rho = _axis_distances(p, res.x[:4])
    return {"zone": np.ptp(rho), "outer": rho.max(), "inner": rho.min()}[kind]


# --------------------------------------------------------------------------------------
# exact geometry: form error zero, known zones


def test_points_on_perfect_elements_give_zero_zone_width():
    """Points on an exact line, plane, circle, sphere or cylinder, anywhere in space."""
    rng = np.random.default_rng(1)
    t = rng.uniform(-50.0, 50.0, 25)
    line2 = np.c_[t, 0.3 * t] + [12.0, -7.0]
    assert straightness(line2).form_error <= 1e-9
    line3, _ = _rigid(rng, np.c_[t, np.zeros((25, 2))])
    assert straightness(line3).form_error <= 1e-9
    plane, _ = _rigid(rng, np.c_[rng.uniform(-50, 50, (30, 2)), np.zeros(30)])
    assert flatness(plane).form_error <= 1e-9
    circle2 = _ring(rng, 20, 25.0, 0.0) + np.array([3.0, 4.0])
    for solve in (roundness, inscribed_circle, circumscribed_circle):
        result = solve(circle2)
        assert result.form_error <= 1e-9
        assert result.element.radius == pytest.approx(25.0, abs=1e-9)
        np.testing.assert_allclose(result.element.centre, [3.0, 4.0], atol=1e-9)
    circle3, rot = _rigid(rng, np.c_[_ring(rng, 20, 25.0, 0.0), np.zeros(20)])
    assert roundness(circle3).form_error <= 1e-9
    assert roundness(circle3, normal=rot[:, 2]).form_error <= 1e-9
    ball = _ball(rng, 25, 9.525, 0.0) + np.array([100.0, -50.0, 20.0])
    for solve in (sphericity, inscribed_sphere, circumscribed_sphere):
        result = solve(ball)
        assert result.form_error <= 1e-9
        assert result.element.radius == pytest.approx(9.525, abs=1e-9)
    shaft, rot = _rigid(rng, _shaft(rng, 40, 20.0, 60.0, 0.0))
    for solve in (cylindricity, inscribed_cylinder, circumscribed_cylinder):
        result = solve(shaft)
        assert result.form_error <= 1e-9
        assert result.element.radius == pytest.approx(20.0, abs=1e-9)
        assert abs(result.element.direction @ rot[:, 2]) == pytest.approx(1.0, abs=1e-12)


def test_roundness_of_points_alternating_on_two_concentric_circles_is_their_separation():
    """24 points alternating between radii R - t/2 and R + t/2: the zone is exactly t."""
    t, radius = 0.004, 30.0
    angle = np.arange(24) * np.pi / 12
    r = radius + t * (np.arange(24) % 2 - 0.5)
    points = np.c_[r * np.cos(angle), r * np.sin(angle)] + [7.0, -2.0]
    result = roundness(points)
    assert result.form_error == pytest.approx(t, abs=1e-12)
    assert result.bounds == pytest.approx((radius - t / 2, radius + t / 2), abs=1e-12)
    np.testing.assert_allclose(result.element.centre, [7.0, -2.0], atol=1e-12)
    assert len(result.contacts) == 24
    assert result.converged


def test_roundness_in_a_given_plane_of_a_tilted_3d_profile():
    rng = np.random.default_rng(2)
    t, radius = 0.002, 12.0
    angle = np.arange(16) * np.pi / 8
    r = radius + t * (np.arange(16) % 2 - 0.5)
    # Out-of-plane scatter must not count: roundness is measured in the given plane.
    local = np.c_[r * np.cos(angle), r * np.sin(angle), rng.uniform(-0.05, 0.05, 16)]
    points, rot = _rigid(rng, local)
    result = roundness(points, normal=rot[:, 2])
    assert result.form_error == pytest.approx(t, abs=1e-12)
    assert isinstance(result.element, Circle)
    np.testing.assert_allclose(np.abs(result.element.normal @ rot[:, 2]), 1.0, atol=1e-12)


def test_sphericity_of_points_alternating_on_two_concentric_spheres():
    """Antipodal pairs on the inner and outer sphere in many directions: zone exactly t."""
    rng = np.random.default_rng(3)
    t, radius = 0.003, 10.0
    u = _unit_vectors(rng, 30)
    points = np.r_[(radius - t / 2) * u, -(radius + t / 2) * u] + [5.0, 6.0, 7.0]
    result = sphericity(points)
    assert result.form_error == pytest.approx(t, abs=1e-12)
    np.testing.assert_allclose(result.element.centre, [5.0, 6.0, 7.0], atol=1e-11)


def test_cylindricity_of_points_alternating_on_two_coaxial_cylinders():
    rng = np.random.default_rng(4)
    t, radius = 0.002, 15.0
    angle = np.tile(np.arange(12) * np.pi / 6, 4)
    z = np.repeat([-30.0, -10.0, 10.0, 30.0], 12)
    r = radius + t * ((np.arange(48) + np.arange(48) // 12) % 2 - 0.5)
    points, rot = _rigid(rng, np.c_[r * np.cos(angle), r * np.sin(angle), z])
    result = cylindricity(points)
    assert result.form_error == pytest.approx(t, abs=1e-11)
    assert isinstance(result.element, Cylinder)
    assert abs(result.element.direction @ rot[:, 2]) == pytest.approx(1.0, abs=1e-12)


def test_flatness_of_a_thin_wide_plate_far_from_the_origin():
    """A 500 mm plate with points alternating on z = +-0.5 µm, 1 m from the origin: the
    exact zone survives the 1e9 aspect ratio (whitened hull)."""
    rng = np.random.default_rng(5)
    t = 1e-3 * 1e-3  # 1 µm, in mm
    xy = rng.uniform(-250.0, 250.0, (60, 2))
    local = np.c_[xy, t * (np.arange(60) % 2 - 0.5)]
    points, rot = _rigid(rng, local, offset=1000.0)
    result = flatness(points)
    assert result.form_error == pytest.approx(t, abs=1e-12)
    assert abs(result.element.normal @ rot[:, 2]) == pytest.approx(1.0, abs=1e-12)
    assert isinstance(result.element, Plane)


def test_straightness_of_a_profile_in_a_given_plane_equals_the_2d_zone():
    rng = np.random.default_rng(6)
    profile = np.c_[np.linspace(0.0, 80.0, 15), 0.01 * rng.normal(size=15)]
    points, rot = _rigid(rng, np.c_[profile, np.zeros(15)])
    in_plane = straightness(points, plane_normal=rot[:, 2])
    assert in_plane.form_error == pytest.approx(straightness(profile).form_error, abs=1e-12)
    assert in_plane.element.dim == 3
    np.testing.assert_allclose(np.abs(in_plane.element.direction @ rot[:, 0]), 1.0, atol=1e-6)


# --------------------------------------------------------------------------------------
# agreement with brute-force references on small sets


@pytest.mark.parametrize("seed", range(8))
def test_flatness_equals_exhaustive_search_over_point_triples_and_pairs(seed):
    rng = np.random.default_rng(100 + seed)
    n = rng.integers(4, 9)
    # Thin plates (face-vertex zones) and, for odd seeds, blobs (often edge-edge zones).
    thickness = 10.0 if seed % 2 else 0.01
    local = np.c_[rng.uniform(-20, 20, (n, 2)), thickness * rng.normal(size=n)]
    points, _ = _rigid(rng, local)
    result = flatness(points)
    assert result.form_error == pytest.approx(_flatness_exhaustive(points), abs=1e-12)
    # The reported zone is real: every point within +-t/2 of the mid plane.
    d = result.element.distances(points)
    assert np.ptp(d) == pytest.approx(result.form_error, abs=1e-12)
    assert len(result.contacts) >= 4


def test_flatness_of_a_regular_tetrahedron_is_its_edge_over_sqrt2():
    """Non-flat data exercise the edge-edge case: a regular tetrahedron's width is its
    edge length over sqrt(2), attained between two opposite edges."""
    tetra = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
    edge = 2.0 * np.sqrt(2.0)
    assert flatness(tetra).form_error == pytest.approx(edge / np.sqrt(2.0), rel=1e-14)
    assert flatness(tetra).form_error == pytest.approx(_flatness_exhaustive(tetra), rel=1e-14)


@pytest.mark.parametrize("seed", range(8))
def test_straightness_2d_equals_exhaustive_search_over_point_pairs(seed):
    rng = np.random.default_rng(200 + seed)
    n = rng.integers(3, 12)
    points = np.c_[np.sort(rng.uniform(0, 50, n)), 0.02 * rng.normal(size=n)] + [3.0, 1.0]
    result = straightness(points)
    assert result.form_error == pytest.approx(_straightness_exhaustive(points), abs=1e-12)
    assert isinstance(result.element, Line)
    assert np.ptp(result.element.distances(points)) == pytest.approx(result.form_error, abs=1e-12)


@pytest.mark.parametrize("seed", range(6))
def test_roundness_equals_exhaustive_search_over_four_point_zones(seed):
    rng = np.random.default_rng(300 + seed)
    points = _ring(rng, 8, 10.0, 0.01) + rng.uniform(-5, 5, 2)
    result = roundness(points)
    assert result.form_error == pytest.approx(_zone_exhaustive(points, 4), abs=1e-12)
    assert len(result.contacts) >= 4


@pytest.mark.parametrize("seed", range(4))
def test_sphericity_equals_exhaustive_search_over_five_point_zones(seed):
    rng = np.random.default_rng(400 + seed)
    points = _ball(rng, 8, 6.0, 0.01) + rng.uniform(-5, 5, 3)
    result = sphericity(points)
    assert result.form_error == pytest.approx(_zone_exhaustive(points, 5), abs=1e-12)
    assert len(result.contacts) >= 5


@pytest.mark.parametrize("seed", range(6))
def test_circumscribed_circle_equals_exhaustive_two_and_three_point_circles(seed):
    rng = np.random.default_rng(500 + seed)
    # Arbitrary scattered points, not only round ones: MCC is convex, hence global.
    points = rng.uniform(-10, 10, (9, 2)) if seed % 2 else _ring(rng, 9, 10.0, 0.5)
    result = circumscribed_circle(points)
    assert result.element.radius == pytest.approx(_enclosing_exhaustive(points), abs=1e-12)
    assert np.all(result.element.distances(points) <= 1e-12)
    assert 2 <= len(result.contacts) <= 3


@pytest.mark.parametrize("seed", range(4))
def test_circumscribed_sphere_equals_exhaustive_two_to_four_point_spheres(seed):
    rng = np.random.default_rng(600 + seed)
    points = rng.uniform(-10, 10, (8, 3)) if seed % 2 else _ball(rng, 8, 10.0, 0.5)
    result = circumscribed_sphere(points)
    assert result.element.radius == pytest.approx(_enclosing_exhaustive(points), abs=1e-12)
    assert np.all(result.element.distances(points) <= 1e-12)


@pytest.mark.parametrize("seed", range(6))
def test_inscribed_circle_equals_the_largest_empty_circle_from_voronoi_vertices(seed):
    rng = np.random.default_rng(700 + seed)
    points = _ring(rng, 12, 10.0, 0.4) + rng.uniform(-5, 5, 2)
    result = inscribed_circle(points)
    assert result.element.radius == pytest.approx(_largest_empty_circle(points), abs=1e-12)
    assert np.all(result.element.distances(points) >= -1e-12)
    assert len(result.contacts) >= 3


@pytest.mark.parametrize(
    ("solve", "kind"),
    [(cylindricity, "zone"), (circumscribed_cylinder, "outer"), (inscribed_cylinder, "inner")],
)
def test_cylinder_zones_match_a_slsqp_epigraph_reference(solve, kind):
    rng = np.random.default_rng(800)
    points = _shaft(rng, 30, 8.0, 40.0, 0.01)
    result = solve(points)
    reference = _axis_epigraph(points, kind)
    value = {"zone": result.form_error, "outer": result.bounds[1], "inner": result.bounds[0]}
    assert value[kind] == pytest.approx(reference, abs=1e-9)


def test_straightness_3d_is_the_diameter_of_the_smallest_enclosing_cylinder():
    """Against SLSQP on the circumscribed-cylinder epigraph (ISO 12780-1 MZCY)."""
    rng = np.random.default_rng(801)
    points = np.c_[0.01 * rng.normal(size=(20, 2)), np.linspace(-40, 40, 20)]
    result = straightness(points)
    assert result.form_error == pytest.approx(2.0 * _axis_epigraph(points, "outer"), abs=1e-9)
    assert np.max(result.element.distances(points)) == pytest.approx(result.bounds[1], abs=1e-12)


# --------------------------------------------------------------------------------------
# never worse than least squares; invariance


def test_minimum_zone_never_exceeds_the_least_squares_peak_to_valley():
    """80 random data sets of each feature: the zone is at most the LS form error that
    part C's fit reports (same residual definition), and the result says so too."""
    rng = np.random.default_rng(900)
    for _ in range(80):
        form = rng.uniform(1e-4, 0.05)
        plate, _ = _rigid(rng, np.c_[rng.uniform(-30, 30, (15, 2)), form * rng.normal(size=15)])
        ring = _ring(rng, 12, rng.uniform(2, 50), form)
        ball = _ball(rng, 15, rng.uniform(2, 50), form)
        cases = [
            (flatness(plate), fit_plane(plate).form_error),
            (roundness(ring), fit_circle(ring).form_error),
            (sphericity(ball), fit_sphere(ball).form_error),
        ]
        for result, ls_form_error in cases:
            assert result.converged
            assert result.form_error <= ls_form_error + 1e-12
            assert result.least_squares_form_error == pytest.approx(ls_form_error, abs=1e-9)
    for _ in range(10):
        shaft, _ = _rigid(rng, _shaft(rng, 25, 10.0, 30.0, 0.01))
        assert cylindricity(shaft).form_error <= fit_cylinder(shaft).form_error + 1e-12
        line = np.c_[0.01 * rng.normal(size=(12, 2)), np.linspace(0, 50, 12)]
        assert straightness(line).form_error <= fit_line(line).form_error + 1e-12


@settings(max_examples=25, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    angles=st.tuples(*[st.floats(-np.pi, np.pi)] * 3),
    shift=st.tuples(*[st.floats(-500, 500)] * 3),
)
def test_zones_are_invariant_under_rigid_motions(seed, angles, shift):
    rng = np.random.default_rng(seed)
    rot = Rotation.from_euler("xyz", angles).as_matrix()
    plate = np.c_[rng.uniform(-30, 30, (12, 2)), 0.01 * rng.normal(size=12)]
    ball = _ball(rng, 12, 10.0, 0.01)
    moved = [p @ rot.T + np.array(shift) for p in (plate, ball)]
    assert flatness(moved[0]).form_error == pytest.approx(flatness(plate).form_error, abs=1e-11)
    assert sphericity(moved[1]).form_error == pytest.approx(sphericity(ball).form_error, abs=1e-11)


# --------------------------------------------------------------------------------------
# results and errors


def test_zone_result_is_frozen_and_reports_its_method():
    rng = np.random.default_rng(10)
    result = circumscribed_circle(_ring(rng, 10, 5.0, 0.01))
    assert isinstance(result, ZoneResult)
    assert result.method == "circumscribed"
    assert result.converged is True and result.iterations >= 1
    s = "" if result.iterations == 1 else "s"
    assert result.message == f"converged: {result.iterations} linear programme{s}"
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.form_error = 0.0  # type: ignore[misc]
    assert isinstance(sphericity(_ball(rng, 10, 5.0, 0.01)).element, Sphere)


def test_a_zone_stopped_by_the_iteration_limit_is_flagged_not_converged(monkeypatch):
    """The failure path (scipy's ``max_nfev=1`` test): one linear programme is not enough
    to reach the circumscribed circle from the least-squares start."""
    monkeypatch.setattr(minimax, "_MAX_ITERATIONS", 1)
    result = circumscribed_circle(_ring(np.random.default_rng(10), 10, 5.0, 0.01))
    assert (result.status, result.success, result.converged) == (0, False, False)
    assert result.iterations == 1
    assert result.message == "no convergence in 1 linear programme"


def test_zone_status_follows_the_least_squares_convention():
    """Shared codes mean the same as :class:`mtmetrology.optimize.Status` (0 iteration limit,
    2 rounding level, 3 exact), success is ``status > 0``, and every code has a message."""
    assert {ZoneStatus.ITERATION_LIMIT, ZoneStatus.ROUNDING_LEVEL, ZoneStatus.EXACT} == {
        Status.ITERATION_LIMIT,
        Status.ROUNDING_LEVEL,
        Status.EXACT,
    }
    assert set(ZONE_STATUS_MESSAGES) == set(ZoneStatus)
    exact = flatness([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, 0.5, 0.003]])
    assert (exact.status, exact.success, exact.iterations) == (ZoneStatus.EXACT, True, 0)
    assert exact.message == ZONE_STATUS_MESSAGES[ZoneStatus.EXACT]
    for status in ZoneStatus:
        failed = dataclasses.replace(exact, status=int(status))
        assert failed.success is failed.converged is (status > 0)


def test_inscribed_circle_of_a_partial_arc_is_refused_as_unbounded():
    """Points on a quarter arc do not surround a centre: the empty circle grows without
    limit away from them, which must be an error, not a huge number."""
    rng = np.random.default_rng(11)
    angle = rng.uniform(0.0, np.pi / 2, 30)
    arc = 20.0 * np.c_[np.cos(angle), np.sin(angle)]
    with pytest.raises(FitError, match="inscribed circle is unbounded"):
        inscribed_circle(arc)
    # The other criteria are well posed on the arc.
    assert roundness(arc).form_error <= 1e-9
    assert circumscribed_circle(arc).converged


@pytest.mark.parametrize(
    ("solve", "points", "match"),
    [
        (roundness, [[0, 0], [1, 1], [2, 2], [3, 3]], "collinear"),
        (inscribed_circle, [[0, 0, 0], [1, 1, 1], [2, 2, 2]], "collinear"),
        (sphericity, [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [2, 3, 0]], "coplanar"),
        (circumscribed_sphere, [[0, 0, 0], [1, 0, 0], [0, 1, 0]], "fewer than the 4 needed"),
        (flatness, [[0, 0, 0], [1, 0, 0]], "fewer than the 3 needed"),
        (flatness, [[0, 0, 0], [1, 1, 1], [2, 2, 2], [5, 5, 5]], "collinear"),
        (cylindricity, [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], "fewer than the 5 needed"),
        (straightness, [[1, 2], [1, 2], [1, 2]], "coincident"),
        (roundness, [[0, 0], [1, np.nan], [2, 1], [0, 3]], "point 1 is not finite"),
        (flatness, [[0, 0], [1, 0], [0, 1]], r"shape \(n, 3\)"),
        (straightness, [[0, 0], [1, 0], [2, 0.1]], "plane_normal applies to points in 3-D"),
    ],
)
def test_degenerate_input_is_refused_with_a_clear_message(solve, points, match):
    kwargs = {"plane_normal": [0, 0, 1]} if "plane_normal" in match else {}
    with pytest.raises(FitError, match=match):
        solve(points, **kwargs)
