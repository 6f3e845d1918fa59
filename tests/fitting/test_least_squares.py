"""Tests of mtmetrology.fitting.least_squares.

Reference values come from exact geometry, from high-precision fits computed here with
mpmath (50 digits, Gauss–Newton started from the float solution) on NIST-like data sets
(partial arcs, micrometre form error, offsets far from the origin), and from central
differences of the whole fit.
"""

from __future__ import annotations

import mpmath as mp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from mtmetrology.fitting.elements import Plane
from mtmetrology.fitting.least_squares import (
    FitError,
    fit_circle,
    fit_cone,
    fit_cylinder,
    fit_line,
    fit_plane,
    fit_sphere,
)
from mtmetrology.optimize import Status

TOL_MM = 1e-9
TOL_RAD = 1e-9


def _pose(seed: int, offset_scale: float = 500.0) -> tuple[np.ndarray, np.ndarray]:
    rot = Rotation.random(random_state=seed).as_matrix()
    offset = np.random.default_rng(seed).uniform(-offset_scale, offset_scale, 3)
    return rot, offset


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """Angle between two undirected axes (rad)."""
    return float(np.arctan2(np.linalg.norm(np.cross(a, b)), abs(a @ b)))


def _sphere_points(rng, n, radius, cap=np.pi / 2):
    """n points on a spherical cap of polar half-angle ``cap`` about +z."""
    polar = np.arccos(rng.uniform(np.cos(cap), 1.0, n))
    azimuth = rng.uniform(0, 2 * np.pi, n)
    return radius * np.column_stack(
        [np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)]
    )


def _cylinder_points(rng, n, radius, length, arc=2 * np.pi):
    theta = rng.uniform(0, arc, n)
    z = rng.uniform(-length / 2, length / 2, n)
    return np.column_stack([radius * np.cos(theta), radius * np.sin(theta), z])


def _cone_points(rng, n, psi, z_range=(10.0, 40.0), arc=2 * np.pi):
    theta = rng.uniform(0, arc, n)
    z = rng.uniform(*z_range, n)
    r = z * np.tan(psi)
    return np.column_stack([r * np.cos(theta), r * np.sin(theta), z])


# ---------------------------------------------------------------- exact geometry


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_exact_sphere_recovered(seed):
    rot, off = _pose(seed)
    rng = np.random.default_rng(seed)
    pts = _sphere_points(rng, 25, 9.525) @ rot.T + off
    fit = fit_sphere(pts)
    assert np.linalg.norm(fit.element.centre - off) < TOL_MM
    assert abs(fit.element.radius - 9.525) < TOL_MM
    assert fit.success and fit.form_error < TOL_MM
    known = fit_sphere(pts[:5], radius=9.525)
    assert np.linalg.norm(known.element.centre - off) < TOL_MM
    assert known.element.radius == 9.525


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_exact_circle_recovered_2d_and_3d(seed):
    rot, off = _pose(seed)
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0, 2.0, 9)  # a 115° arc
    flat = 31.75 * np.column_stack([np.cos(theta), np.sin(theta)])
    fit2 = fit_circle(flat + off[:2])
    assert np.linalg.norm(fit2.element.centre - off[:2]) < TOL_MM
    assert abs(fit2.element.radius - 31.75) < TOL_MM
    pts3 = np.column_stack([flat, np.zeros(9)]) @ rot.T + off
    fit3 = fit_circle(pts3)
    assert np.linalg.norm(fit3.element.centre - off) < TOL_MM
    assert abs(fit3.element.radius - 31.75) < TOL_MM
    assert _angle(fit3.element.normal, rot[:, 2]) < TOL_RAD


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_exact_cylinder_recovered(seed):
    rot, off = _pose(seed)
    rng = np.random.default_rng(seed)
    pts = _cylinder_points(rng, 30, 12.0, 40.0) @ rot.T + off
    fit = fit_cylinder(pts)
    e = fit.element
    assert _angle(e.direction, rot[:, 2]) < TOL_RAD
    assert abs(e.radius - 12.0) < TOL_MM
    # The reported point lies on the true axis, at the foot of the centroid.
    foot = off + ((pts.mean(axis=0) - off) @ rot[:, 2]) * rot[:, 2]
    assert np.linalg.norm(e.point - foot) < TOL_MM


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("psi", [0.15, 0.5, 1.0])
def test_exact_cone_recovered(seed, psi):
    rot, off = _pose(seed)
    rng = np.random.default_rng(seed)
    pts = _cone_points(rng, 30, psi) @ rot.T + off
    fit = fit_cone(pts)
    e = fit.element
    assert abs(e.half_angle - psi) < TOL_RAD
    assert np.linalg.norm(e.direction - rot[:, 2]) < TOL_RAD  # points into the cone
    assert np.linalg.norm(e.apex - off) < 1e-9 / np.sin(psi)
    assert fit.success


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_exact_plane_and_lines_recovered(seed):
    rot, off = _pose(seed)
    rng = np.random.default_rng(seed)
    pts = np.column_stack([rng.uniform(-60, 60, (15, 2)), np.zeros(15)]) @ rot.T + off
    plane = fit_plane(pts).element
    assert _angle(plane.normal, rot[:, 2]) < TOL_RAD
    assert abs((plane.point - off) @ rot[:, 2]) < TOL_MM
    line_pts = np.outer(rng.uniform(-60, 60, 8), rot[:, 0]) + off
    line = fit_line(line_pts).element
    assert _angle(line.direction, rot[:, 0]) < TOL_RAD
    assert np.linalg.norm(np.cross(line.point - off, rot[:, 0])) < TOL_MM
    line2 = fit_line(line_pts[:, :2]).element
    d2 = rot[:2, 0] / np.linalg.norm(rot[:2, 0])
    assert abs(line2.direction @ [-d2[1], d2[0]]) < TOL_RAD
    assert abs((line2.point - off[:2]) @ [-d2[1], d2[0]]) < TOL_MM


def test_residuals_are_element_distances_and_form_error_is_peak_to_valley():
    rng = np.random.default_rng(5)
    pts = _sphere_points(rng, 25, 10.0) * (1 + 1e-4 * rng.standard_normal(25))[:, None]
    fit = fit_sphere(pts)
    np.testing.assert_allclose(fit.residuals, fit.element.distances(pts), atol=1e-14)
    assert fit.form_error == pytest.approx(fit.residuals.max() - fit.residuals.min())
    assert fit.rms == pytest.approx(np.sqrt(np.mean(fit.residuals**2)))
    assert fit.status in (Status.STEP_TOLERANCE, Status.ROUNDING_LEVEL) and fit.nit >= 1
    line = fit_line(rng.normal(size=(10, 3)) * [10, 0.01, 0.01])
    assert line.status == Status.EXACT and line.nit == 0
    assert line.form_error == pytest.approx(2 * line.residuals.max())
    assert np.all(line.residuals >= 0)


# ------------------------------------------------------- rigid-motion invariance


_rotations = st.integers(0, 2**31 - 1).map(lambda s: Rotation.random(random_state=s).as_matrix())
_offsets = st.lists(st.floats(-800, 800), min_size=3, max_size=3).map(np.array)


def _noisy(pts: np.ndarray, seed: int, sigma: float = 2e-3) -> np.ndarray:
    return pts + sigma * np.random.default_rng(seed).standard_normal(pts.shape)


BASE_RNG = np.random.default_rng(11)
SPHERE_PTS = _noisy(_sphere_points(BASE_RNG, 20, 15.0, cap=1.2), 1)
CYL_PTS = _noisy(_cylinder_points(BASE_RNG, 25, 8.0, 30.0, arc=4.0), 2)
CONE_PTS = _noisy(_cone_points(BASE_RNG, 25, 0.35), 3)
PLANE_PTS = _noisy(np.column_stack([BASE_RNG.uniform(-40, 40, (12, 2)), np.zeros(12)]), 4)
_ARC = BASE_RNG.uniform(0, 2.5, 9)
CIRCLE_PTS = _noisy(np.column_stack([22 * np.cos(_ARC), 22 * np.sin(_ARC), np.zeros(9)]), 5)


@settings(max_examples=15, deadline=None)
@given(rot=_rotations, off=_offsets)
def test_fits_move_with_the_points(rot, off):
    """Rigid motion of the points moves the fitted element; radii and residuals stay."""
    cases = [
        (fit_sphere, SPHERE_PTS, ("centre",), ()),
        (fit_cylinder, CYL_PTS, ("point",), ("direction",)),
        (fit_cone, CONE_PTS, ("apex",), ("direction",)),
        (fit_plane, PLANE_PTS, ("point",), ("normal",)),
        (fit_circle, CIRCLE_PTS, ("centre",), ("normal",)),
        (fit_line, CYL_PTS, ("point",), ("direction",)),
    ]
    for fit, pts, point_attrs, dir_attrs in cases:
        a = fit(pts)
        b = fit(pts @ rot.T + off)
        # A plane's normal follows a sign convention, so its residuals may change sign.
        sign = np.sign(b.element.normal @ rot @ a.element.normal) if fit is fit_plane else 1.0
        np.testing.assert_allclose(b.residuals * sign, a.residuals, atol=1e-9)
        for name in point_attrs:
            moved = getattr(a.element, name) @ rot.T + off
            assert np.linalg.norm(getattr(b.element, name) - moved) < 1e-8, (fit, name)
        for name in dir_attrs:
            assert _angle(getattr(b.element, name), rot @ getattr(a.element, name)) < 1e-9
        for name in ("radius", "half_angle"):
            if hasattr(a.element, name):
                assert getattr(b.element, name) == pytest.approx(getattr(a.element, name), abs=1e-9)


# ---------------------------------------------------- high-precision references


@pytest.fixture(autouse=True)
def _fifty_digits():
    """mpmath at 50 significant digits for the reference fits, restored afterwards."""
    with mp.workdps(50):
        yield


def _mp_gauss_newton(residuals, beta, iterations=40):
    """Gauss–Newton in mpmath with a central-difference Jacobian (h = 1e-20 at 50 digits,
    truncation error ~1e-40); returns the parameters at convergence."""
    beta = [mp.mpf(b) for b in beta]
    h = mp.mpf("1e-20")
    for _ in range(iterations):
        r = residuals(beta)
        cols = []
        for k in range(len(beta)):
            bp, bm = list(beta), list(beta)
            bp[k] += h
            bm[k] -= h
            rp, rm = residuals(bp), residuals(bm)
            cols.append([(rp[i] - rm[i]) / (2 * h) for i in range(len(r))])
        jac = mp.matrix(len(r), len(beta))
        for k, col in enumerate(cols):
            for i, value in enumerate(col):
                jac[i, k] = value
        step = mp.lu_solve(jac.T * jac, -(jac.T * mp.matrix(r)))
        beta = [b + s for b, s in zip(beta, step, strict=True)]
        if mp.norm(step) < mp.mpf("1e-35"):
            break
    return beta


def _mp_points(pts):
    return [[mp.mpf(float(c)) for c in p] for p in pts]


def _mp_local(pts_mp, origin, frame):
    """Points in a local frame (rows of ``frame`` are the axes), in mpmath."""
    out = []
    for p in pts_mp:
        v = [p[k] - mp.mpf(float(origin[k])) for k in range(3)]
        out.append([sum(mp.mpf(float(frame[i, k])) * v[k] for k in range(3)) for i in range(3)])
    return out


def _frame(axis):
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(axis, e1), axis])


def _to_global(vec_local, origin, frame):
    return np.asarray([float(v) for v in vec_local]) @ frame + origin


def _form_error(rng, pts, normals, amplitude):
    """Add lobed plus random form error along the given unit normals."""
    lobes = np.sin(3 * np.arctan2(pts[:, 1], pts[:, 0]))
    return pts + (amplitude * (lobes + 0.5 * rng.standard_normal(len(pts))))[:, None] * normals


def test_sphere_agrees_with_mpmath_reference_on_partial_cap_far_from_origin():
    rng = np.random.default_rng(21)
    rot, _ = _pose(21)
    off = np.array([812.0, -433.0, 615.0])
    local = _sphere_points(rng, 20, 25.0, cap=0.6)  # a 69° cap
    local = _form_error(rng, local, local / 25.0, 2e-3)
    pts = local @ rot.T + off
    fit = fit_sphere(pts)
    pm = _mp_points(pts)
    c0 = fit.element.centre

    def res(b):
        return [mp.sqrt(sum((p[k] - b[k]) ** 2 for k in range(3))) - b[3] for p in pm]

    ref = _mp_gauss_newton(res, [*c0, fit.element.radius])
    assert np.linalg.norm(c0 - np.array([float(v) for v in ref[:3]])) < TOL_MM
    assert abs(fit.element.radius - float(ref[3])) < TOL_MM
    # Known-radius centre (SAMBA style) against its own reference.
    fit_r = fit_sphere(pts[:5], radius=25.0)

    def res_r(b):
        return [mp.sqrt(sum((p[k] - b[k]) ** 2 for k in range(3))) - 25 for p in pm[:5]]

    ref_r = _mp_gauss_newton(res_r, list(fit_r.element.centre))
    assert np.linalg.norm(fit_r.element.centre - np.array([float(v) for v in ref_r])) < TOL_MM


def test_circle_2d_agrees_with_mpmath_reference_on_short_arc():
    rng = np.random.default_rng(22)
    theta = np.sort(rng.uniform(0, np.pi / 3, 12))  # a 60° arc, as in the NIST sets
    radial = np.column_stack([np.cos(theta), np.sin(theta)])
    pts = (50.0 + 1e-3 * np.sin(5 * theta) + 5e-4 * rng.standard_normal(12))[:, None] * radial
    pts = pts + np.array([1500.0, -2200.0])
    fit = fit_circle(pts)
    pm = [[mp.mpf(float(c)) for c in p] for p in pts]

    def res(b):
        return [mp.sqrt((p[0] - b[0]) ** 2 + (p[1] - b[1]) ** 2) - b[2] for p in pm]

    ref = _mp_gauss_newton(res, [*fit.element.centre, fit.element.radius])
    assert np.linalg.norm(fit.element.centre - np.array([float(v) for v in ref[:2]])) < TOL_MM
    assert abs(fit.element.radius - float(ref[2])) < TOL_MM


def test_circle_3d_agrees_with_two_stage_mpmath_reference():
    rng = np.random.default_rng(23)
    rot, off = _pose(23)
    theta = rng.uniform(0, 1.5, 10)
    local = np.column_stack([40 * np.cos(theta), 40 * np.sin(theta), np.zeros(10)])
    local = _form_error(rng, local, np.tile([0.0, 0.0, 1.0], (10, 1)), 1e-3)
    local = _form_error(rng, local, local * [1, 1, 0] / 40.0, 1e-3)
    pts = local @ rot.T + off
    fit = fit_circle(pts)
    e = fit.element
    frame = _frame(e.normal)
    pl = _mp_local(_mp_points(pts), e.centre, frame)

    def plane_res(b):  # plane z = b0 + b1 x + b2 y
        k = mp.sqrt(1 + b[1] ** 2 + b[2] ** 2)
        return [(p[2] - b[0] - b[1] * p[0] - b[2] * p[1]) / k for p in pl]

    bp = _mp_gauss_newton(plane_res, [0, 0, 0])
    k = mp.sqrt(1 + bp[1] ** 2 + bp[2] ** 2)
    nrm = [-bp[1] / k, -bp[2] / k, 1 / k]
    u1 = [1 - nrm[0] ** 2, -nrm[0] * nrm[1], -nrm[0] * nrm[2]]
    nu = mp.sqrt(sum(c**2 for c in u1))
    u1 = [c / nu for c in u1]
    u2 = [
        nrm[1] * u1[2] - nrm[2] * u1[1],
        nrm[2] * u1[0] - nrm[0] * u1[2],
        nrm[0] * u1[1] - nrm[1] * u1[0],
    ]
    o = [0, 0, bp[0]]
    uv = [
        [sum((p[i] - o[i]) * u1[i] for i in range(3)), sum((p[i] - o[i]) * u2[i] for i in range(3))]
        for p in pl
    ]

    def circle_res(b):
        return [mp.sqrt((q[0] - b[0]) ** 2 + (q[1] - b[1]) ** 2) - b[2] for q in uv]

    bc = _mp_gauss_newton(circle_res, [0, 0, e.radius])
    centre_local = [o[i] + bc[0] * u1[i] + bc[1] * u2[i] for i in range(3)]
    centre = _to_global(centre_local, e.centre, frame)
    assert np.linalg.norm(e.centre - centre) < TOL_MM
    assert abs(e.radius - float(bc[2])) < TOL_MM
    assert _angle(e.normal, np.array([float(c) for c in nrm]) @ frame) < TOL_RAD


def _axis_reference(fit_element_point, axis, pts, residual_of_local, extra):
    """mpmath fit of an axial element in the float solution's local frame.

    Axis through (b0, b1, 0) with direction (b2, b3, 1)/norm; returns parameters."""
    frame = _frame(axis)
    pl = _mp_local(_mp_points(pts), fit_element_point, frame)

    def res(b):
        k = mp.sqrt(1 + b[2] ** 2 + b[3] ** 2)
        d = [b[2] / k, b[3] / k, 1 / k]
        out = []
        for p in pl:
            v = [p[0] - b[0], p[1] - b[1], p[2]]
            z = sum(v[i] * d[i] for i in range(3))
            rho = mp.sqrt(sum((v[i] - z * d[i]) ** 2 for i in range(3)))
            out.extend(residual_of_local(v, z, rho, b))
        return out

    b = _mp_gauss_newton(res, [0, 0, 0, 0, *extra])
    k = mp.sqrt(1 + b[2] ** 2 + b[3] ** 2)
    direction = np.array([float(b[2] / k), float(b[3] / k), float(1 / k)]) @ frame
    point = _to_global([b[0], b[1], 0], fit_element_point, frame)
    return b, point, direction


def test_cylinder_agrees_with_mpmath_reference_on_partial_surface():
    rng = np.random.default_rng(24)
    rot, off = _pose(24, 1000.0)
    local = _cylinder_points(rng, 24, 20.0, 25.0, arc=2.0)  # 115° of a short bore
    local = _form_error(rng, local, local * [1, 1, 0] / 20.0, 2e-3)
    pts = local @ rot.T + off
    fit = fit_cylinder(pts)
    e = fit.element
    b, point, direction = _axis_reference(
        e.point, e.direction, pts, lambda v, z, rho, b: [rho - b[4]], [e.radius]
    )
    assert _angle(e.direction, direction) < TOL_RAD
    assert np.linalg.norm(np.cross(e.point - point, direction)) < TOL_MM
    assert abs(e.radius - float(b[4])) < TOL_MM


def test_cone_agrees_with_mpmath_reference():
    rng = np.random.default_rng(25)
    rot, off = _pose(25, 1000.0)
    psi = 0.45
    local = _cone_points(rng, 24, psi, arc=4.0)
    normals = np.column_stack(
        [
            np.cos(psi) * local[:, :2] / np.linalg.norm(local[:, :2], axis=1)[:, None],
            -np.sin(psi) * np.ones(24),
        ]
    )
    local = _form_error(rng, local, normals, 2e-3)
    pts = local @ rot.T + off
    fit = fit_cone(pts)
    e = fit.element
    frame_point = e.apex + 25.0 * e.direction  # a point on the axis inside the data

    def cone_res(v, z, rho, b):
        return [rho * mp.cos(b[4]) - z * mp.sin(b[4]) - b[5]]

    s0 = e.distances(frame_point[None, :])[0]
    b, point, direction = _axis_reference(
        frame_point, e.direction, pts, cone_res, [e.half_angle, s0]
    )
    apex = point - float(b[5] / mp.sin(b[4])) * direction
    assert np.linalg.norm(e.direction - direction) < TOL_RAD
    assert abs(e.half_angle - float(b[4])) < TOL_RAD
    assert np.linalg.norm(e.apex - apex) < TOL_MM


def test_plane_and_lines_agree_with_mpmath_reference():
    rng = np.random.default_rng(26)
    rot, off = _pose(26, 1000.0)
    local = np.column_stack([rng.uniform(-80, 80, (20, 2)), np.zeros(20)])
    local = _form_error(rng, local, np.tile([0.0, 0.0, 1.0], (20, 1)), 3e-3)
    pts = local @ rot.T + off
    plane = fit_plane(pts).element
    frame = _frame(plane.normal)
    pl = _mp_local(_mp_points(pts), plane.point, frame)

    def plane_res(b):
        k = mp.sqrt(1 + b[1] ** 2 + b[2] ** 2)
        return [(p[2] - b[0] - b[1] * p[0] - b[2] * p[1]) / k for p in pl]

    b = _mp_gauss_newton(plane_res, [0, 0, 0])
    k = mp.sqrt(1 + b[1] ** 2 + b[2] ** 2)
    normal = np.array([float(-b[1] / k), float(-b[2] / k), float(1 / k)]) @ frame
    assert _angle(plane.normal, normal) < TOL_RAD
    assert abs(float(b[0] / k)) < TOL_MM  # the fitted point lies on the reference plane

    # 3-D line: straightness-like data along e_x with lateral form error.
    t = rng.uniform(-100, 100, 15)
    line_local = np.column_stack([2e-3 * rng.standard_normal((15, 2)), t])
    line_pts = line_local @ rot.T + off
    line = fit_line(line_pts).element
    _, point, direction = _axis_reference(
        line.point,
        line.direction,
        line_pts,
        lambda v, z, rho, b: [v[i] - z * d for i, d in enumerate(_unit_mp(b))],
        [],
    )
    assert _angle(line.direction, direction) < TOL_RAD
    assert np.linalg.norm(np.cross(line.point - point, direction)) < TOL_MM

    # 2-D line y = b0 + b1 x in the fitted line's frame.
    pts2 = line_pts[:, :2]
    line2 = fit_line(pts2).element
    a, nrm = line2.direction, line2.normal
    q = [(mp.mpf(float(p[0] - line2.point[0])), mp.mpf(float(p[1] - line2.point[1]))) for p in pts2]
    loc = [
        (dx * float(a[0]) + dy * float(a[1]), dx * float(nrm[0]) + dy * float(nrm[1]))
        for dx, dy in q
    ]

    def line2_res(b):
        return [(y - b[0] - b[1] * x) / mp.sqrt(1 + b[1] ** 2) for x, y in loc]

    b2 = _mp_gauss_newton(line2_res, [0, 0])
    assert abs(float(mp.atan(b2[1]))) < TOL_RAD
    assert abs(float(b2[0])) < TOL_MM


def _unit_mp(b):
    k = mp.sqrt(1 + b[2] ** 2 + b[3] ** 2)
    return [b[2] / k, b[3] / k, 1 / k]


# ------------------------------------------------------------------ Jacobians


def _central_difference(fit, pts, h=1e-6, attr="parameters"):
    out = np.zeros((len(getattr(fit(pts).element, attr)), *pts.shape))
    for i in range(pts.shape[0]):
        for d in range(pts.shape[1]):
            plus, minus = pts.copy(), pts.copy()
            plus[i, d] += h
            minus[i, d] -= h
            out[:, i, d] = (
                getattr(fit(plus).element, attr) - getattr(fit(minus).element, attr)
            ) / (2 * h)
    return out


def _jacobian_cases(noise):
    rng = np.random.default_rng(31)
    rot, off = _pose(31, 200.0)
    rot2 = np.array([[np.cos(0.7), -np.sin(0.7)], [np.sin(0.7), np.cos(0.7)]])
    theta = rng.uniform(0, 3.0, 10)
    arc3 = np.column_stack([30 * np.cos(theta), 30 * np.sin(theta), np.zeros(10)])
    flat = np.column_stack([rng.uniform(-50, 50, (12, 2)), np.zeros(12)])
    line = np.column_stack([np.zeros((10, 2)), rng.uniform(-50, 50, 10)])
    cases = {
        "sphere": (fit_sphere, _sphere_points(rng, 15, 12.0, cap=1.3)),
        "sphere_known_radius": (lambda p: fit_sphere(p, radius=12.0), _sphere_points(rng, 6, 12.0)),
        "circle_2d": (fit_circle, arc3[:, :2]),
        "circle_3d": (fit_circle, arc3),
        "circle_in_plane": (
            lambda p: fit_circle(p, plane=Plane(off + np.array([0, 0, 0.2]), rot[:, 2])),
            arc3,
        ),
        # A starting axis keeps the many refits of the central differences fast.
        "cylinder": (
            lambda p: fit_cylinder(p, direction=rot[:, 2] + 0.01),
            _cylinder_points(rng, 14, 10.0, 30.0, arc=3.5),
        ),
        "cone": (
            lambda p: fit_cone(p, direction=rot[:, 2] + 0.01),
            _cone_points(rng, 14, 0.4, arc=4.0),
        ),
        "plane": (fit_plane, flat),
        "line_3d": (fit_line, line),
        "line_2d": (fit_line, line[:, 1:]),
    }
    out = {}
    for name, (fit, local) in cases.items():
        pts = local @ rot.T + off if local.shape[1] == 3 else local @ rot2.T + off[:2]
        pts = pts + noise * rng.standard_normal(pts.shape)
        out[name] = (fit, pts)
    return out


@pytest.mark.parametrize("name", list(_jacobian_cases(0.0)))
def test_parameter_jacobian_matches_central_differences_at_zero_residual(name):
    """At a zero-residual fit the first-order implicit-function Jacobian is exact:
    relative agreement 1e-6 with central differences (h = 1e-6 mm, whose truncation
    error is ~1e-12 relative and rounding ~1e-10/1e-6 = 1e-10)."""
    fit, pts = _jacobian_cases(0.0)[name]
    analytic = fit(pts).parameter_jacobian
    numeric = _central_difference(fit, pts)
    assert np.abs(analytic - numeric).max() <= 1e-6 * np.abs(numeric).max()


@pytest.mark.parametrize("name", list(_jacobian_cases(0.0)))
def test_parameter_jacobian_first_order_error_scales_with_form_error(name):
    """With 1 µm form error the dropped second-order terms are O(residual/size) ≈ 1e-4
    relative; the bound 2e-3 leaves a margin for the ratio of element sizes."""
    fit, pts = _jacobian_cases(1e-3)[name]
    analytic = fit(pts).parameter_jacobian
    numeric = _central_difference(fit, pts)
    assert np.abs(analytic - numeric).max() <= 2e-3 * np.abs(numeric).max()


@pytest.mark.parametrize(
    "name",
    [
        "sphere",
        "sphere_known_radius",
        "circle_2d",
        "circle_3d",
        "circle_in_plane",
        "cylinder",
        "cone",
        "plane",
        "line_2d",
    ],
)
def test_residual_jacobian_matches_central_differences(name):
    fit, pts = _jacobian_cases(0.0)[name]
    analytic = fit(pts).residual_jacobian()
    numeric = np.zeros_like(analytic)
    h = 1e-6
    for i in range(pts.shape[0]):
        for d in range(pts.shape[1]):
            plus, minus = pts.copy(), pts.copy()
            plus[i, d] += h
            minus[i, d] -= h
            numeric[:, i, d] = (fit(plus).residuals - fit(minus).residuals) / (2 * h)
    assert np.abs(analytic - numeric).max() <= 1e-6 * np.abs(numeric).max()


def test_sphere_covariance_for_symmetric_points_is_three_sigma_squared_over_n():
    """14 points (octahedron + cube vertices) have Σ u uᵀ = (n/3) I and Σ u = 0, so the
    Gauss–Markov covariance is σ²·3/n for each centre coordinate and σ²/n for the radius."""
    octa = np.vstack([np.eye(3), -np.eye(3)])
    cube = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)]) / np.sqrt(3)
    pts = 20.0 * np.vstack([octa, cube]) + [100.0, 50.0, -30.0]
    cov = fit_sphere(pts).parameter_covariance(0.002)
    n = 14
    np.testing.assert_allclose(
        cov, np.diag([3 / n, 3 / n, 3 / n, 1 / n]) * 0.002**2, rtol=1e-12, atol=1e-20
    )


def test_parameter_covariance_matches_monte_carlo():
    """2000 noisy repeats of a circle fit: sample variances vs diag(σ² G Gᵀ).  The
    relative standard error of a sample variance is √(2/2000) ≈ 3.2 %; the tolerance of
    15 % is about 4.7 standard errors (the linearisation error at σ/r = 4e-5 is nil)."""
    rng = np.random.default_rng(41)
    theta = np.linspace(0, 2.5, 12)
    pts = 25.0 * np.column_stack([np.cos(theta), np.sin(theta)])
    sigma = 1e-3
    fit = fit_circle(pts)
    samples = np.array(
        [
            fit_circle(pts + sigma * rng.standard_normal(pts.shape)).element.parameters
            for _ in range(2000)
        ]
    )
    predicted = fit.parameter_covariance(sigma)
    np.testing.assert_allclose(np.var(samples, axis=0), np.diag(predicted), rtol=0.15)


# -------------------------------------------------------------- degenerate input


@pytest.mark.parametrize(
    ("call", "pattern"),
    [
        (lambda: fit_circle(np.column_stack([np.arange(7.0), 2 * np.arange(7.0)])), "collinear"),
        (lambda: fit_circle(np.outer(np.arange(7.0), [1, 2, 3])), "collinear"),
        (
            lambda: fit_sphere(
                np.column_stack([np.random.default_rng(0).normal(size=(9, 2)), np.zeros(9)])
            ),
            "coplanar",
        ),
        (lambda: fit_sphere(np.eye(3)), "fewer than the 4"),
        (lambda: fit_sphere(np.eye(3)[[0, 1, 2, 0]] + [0, 0, 0], radius=2.0), "coplanar"),
        (lambda: fit_sphere(np.eye(4)[:, :3], radius=-1.0), "radius must be a positive"),
        (lambda: fit_cylinder(np.ones((4, 3))), "fewer than the 5"),
        (lambda: fit_cone(np.random.default_rng(1).normal(size=(5, 3))), "fewer than the 6"),
        (lambda: fit_plane(np.outer(np.arange(5.0), [1, 1, 0])), "collinear"),
        (lambda: fit_line(np.ones((4, 3))), "coincide"),
        (lambda: fit_line(np.array([[0.0, 1.0], [np.nan, 2.0], [1.0, 1.0]])), "NaN or inf"),
        (lambda: fit_plane(np.array([[0.0, 0, 0], [1, 0, 0], [0, np.inf, 0]])), "NaN or inf"),
        (lambda: fit_sphere(np.zeros((5, 2))), r"shape \(n, 3\)"),
        (lambda: fit_circle(np.zeros((5, 4))), "shape"),
        (lambda: fit_circle(np.zeros((5, 3)), plane="xy"), "must be a Plane"),
        (
            lambda: fit_cylinder(np.random.default_rng(2).normal(size=(8, 3)), [0, 0, 0]),
            "direction must be",
        ),
    ],
)
def test_degenerate_input_raises_fit_error_naming_the_problem(call, pattern):
    with pytest.raises(FitError, match=pattern):
        call()


def test_fit_error_is_a_value_error_and_names_the_point_count():
    with pytest.raises(ValueError, match=r"circle: the 7 points are collinear"):
        fit_circle(np.column_stack([np.arange(7.0), np.arange(7.0)]))


def test_an_iteration_limit_is_reported_by_status_not_hidden():
    """Issue 8 §3: the fits share the core's status table; a fit stopped by the iteration
    limit says so and is not marked successful."""
    import mtmetrology.fitting.odr as odr

    rng = np.random.default_rng(9)
    pts = _sphere_points(rng, 25, 10.0) * (1 + 1e-3 * rng.standard_normal(25))[:, None]
    limit = odr._MAX_ITER
    try:
        odr._MAX_ITER = 1
        fit = fit_sphere(pts + np.array([50.0, 0.0, 0.0]))
    finally:
        odr._MAX_ITER = limit
    assert fit.status == Status.ITERATION_LIMIT and not fit.success and fit.nit == 1


def test_large_sphere_fit_matches_the_thin_svd_path(monkeypatch):
    """200 000 points: the block-QR (memory-lean) solver path gives the centre and radius
    of the thin-SVD path to 1e-9 mm, and the parameter Jacobian equals −J⁺·u computed
    directly with numpy's pseudo-inverse."""
    import mtmetrology.optimize as optimize

    rng = np.random.default_rng(2009)
    n = 200_000
    u = rng.normal(size=(n, 3))
    centre, radius = np.array([101.0, -52.0, 33.0]), 12.5
    pts = centre + radius * u / np.linalg.norm(u, axis=1, keepdims=True)
    pts += rng.normal(scale=2e-3, size=pts.shape)
    assert optimize._tall(np.empty((n, 4)))
    lean = fit_sphere(pts)
    monkeypatch.setattr(optimize, "_TALL_ROWS", 10 * n)
    assert not optimize._tall(np.empty((n, 4)))
    svd = fit_sphere(pts)
    assert lean.status > 0 and svd.status > 0
    np.testing.assert_allclose(lean.element.centre, svd.element.centre, rtol=0, atol=TOL_MM)
    assert abs(lean.element.radius - svd.element.radius) <= TOL_MM
    # dβ/dP = −J⁺ ∂d/∂P with J = [−u, −1] and ∂d_i/∂P_i = u_i (first-order form)
    v = pts - lean.element.centre
    unit = v / np.linalg.norm(v, axis=1, keepdims=True)
    jac = np.column_stack([-unit, -np.ones(n)])
    expected = -np.linalg.pinv(jac)[:, :, None] * unit[None, :, :]
    np.testing.assert_allclose(lean.parameter_jacobian, expected, rtol=0, atol=1e-15)
