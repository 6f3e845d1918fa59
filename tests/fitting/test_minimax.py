"""Tests for mtmetrology.fitting.minimax (radial Chebyshev elements by sequential LP).

The public functions are also re-exported by :mod:`mtmetrology.fitting.minimum_zone`,
whose tests compare them with exhaustive searches; here: exact solutions of constructed
point sets, the axis model, the LP iteration itself, invariance and refusals.
"""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.fitting import minimax
from mtmetrology.fitting.least_squares import FitError
from mtmetrology.fitting.zones import ZoneStatus

DELTA = 0.003  # mm, radial separation of the constructed zones


def _two_cylinders(r=10.0, delta=DELTA):
    """Eight angles per section, alternating between radii r and r + delta, about z."""
    t = np.arange(8) * np.pi / 4
    radius = r + delta * (np.arange(8) % 2)
    ring = np.column_stack([radius * np.cos(t), radius * np.sin(t)])
    z = np.repeat([-20.0, 0.0, 20.0], 8)
    return np.column_stack([np.tile(ring, (3, 1)), z])


def _octahedron_in_cube(r=5.0, delta=DELTA):
    inner = r * np.vstack([np.eye(3), -np.eye(3)])
    signs = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
    outer = (r + delta) * signs / np.sqrt(3.0)
    return np.vstack([inner, outer])


def _rotation(a, b, c):
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    rx = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rz = np.array([[cc, -sc, 0], [sc, cc, 0], [0, 0, 1]])
    return rz @ ry @ rx


def test_cylinder_zones_of_two_coaxial_cylinders_are_exact():
    p = _two_cylinders()
    zone = minimax.cylindricity(p)
    assert zone.method == "minimum-zone" and zone.status == ZoneStatus.OPTIMAL
    assert zone.form_error == pytest.approx(DELTA, abs=1e-10)
    assert zone.bounds == pytest.approx((10.0, 10.0 + DELTA), abs=1e-10)
    assert abs(zone.element.direction[2]) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_array_equal(zone.contacts, np.arange(24))
    inner = minimax.inscribed_cylinder(p)
    outer = minimax.circumscribed_cylinder(p)
    assert inner.element.radius == pytest.approx(10.0, abs=1e-10)
    assert outer.element.radius == pytest.approx(10.0 + DELTA, abs=1e-10)
    np.testing.assert_array_equal(inner.contacts, np.arange(0, 24, 2))
    np.testing.assert_array_equal(outer.contacts, np.arange(1, 24, 2))
    assert (inner.method, outer.method) == ("inscribed", "circumscribed")


def test_sphere_zones_of_an_octahedron_inside_a_cube_are_exact():
    p = _octahedron_in_cube()
    zone = minimax.sphericity(p)
    assert zone.form_error == pytest.approx(DELTA, abs=1e-10)
    np.testing.assert_allclose(zone.element.centre, 0.0, atol=1e-10)
    assert zone.element.radius == pytest.approx(5.0 + DELTA / 2, abs=1e-10)
    assert minimax.inscribed_sphere(p).element.radius == pytest.approx(5.0, abs=1e-10)
    outer = minimax.circumscribed_sphere(p)
    assert outer.element.radius == pytest.approx(5.0 + DELTA, abs=1e-10)
    np.testing.assert_array_equal(outer.contacts, np.arange(6, 14))


def test_circle_zones_from_an_off_centre_least_squares_start():
    """Two points more on the outer circle pull the least-squares centre off the origin;
    the minimax centre returns to it."""
    t = np.arange(12) * np.pi / 6
    r = 10.0 + DELTA * (np.arange(12) % 2)
    p = np.column_stack([r * np.cos(t), r * np.sin(t)])
    p = np.vstack([p, [[0.0, 10.0 + DELTA], [10.0 * np.cos(0.3), 10.0 * np.sin(0.3)]]])
    zone = minimax.roundness(p)
    assert zone.form_error == pytest.approx(DELTA, abs=1e-10)
    np.testing.assert_allclose(zone.element.centre, 0.0, atol=1e-9)
    assert zone.least_squares_form_error >= zone.form_error
    assert minimax.inscribed_circle(p).element.radius == pytest.approx(10.0, abs=1e-10)
    assert minimax.circumscribed_circle(p).element.radius == pytest.approx(10.0 + DELTA)


def test_roundness_of_a_tilted_3d_profile_in_its_given_plane():
    t = np.arange(12) * np.pi / 6
    r = 10.0 + DELTA * (np.arange(12) % 2)
    flat = np.column_stack([r * np.cos(t), r * np.sin(t), np.zeros(12)])
    rot = _rotation(0.4, -0.2, 1.0)
    p = flat @ rot.T + [5.0, -3.0, 100.0]
    zone = minimax.roundness(p, normal=rot[:, 2])
    assert zone.form_error == pytest.approx(DELTA, abs=1e-10)
    np.testing.assert_allclose(zone.element.centre, [5.0, -3.0, 100.0], atol=1e-9)


@pytest.mark.parametrize("solve", [minimax.cylindricity, minimax.sphericity])
def test_zone_width_is_invariant_under_rigid_motion(solve):
    rng = np.random.default_rng(11)
    base = _two_cylinders() if solve is minimax.cylindricity else _octahedron_in_cube()
    p = base + rng.normal(scale=0.002, size=base.shape)
    moved = p @ _rotation(0.7, 0.2, -1.1).T + [120.0, -40.0, 15.0]
    assert solve(moved).form_error == pytest.approx(solve(p).form_error, rel=1e-7, abs=1e-12)


def test_axis_model_distances_and_jacobian():
    """ρ is the distance from the axis; the Jacobian matches central differences of moved()."""
    rng = np.random.default_rng(3)
    p = rng.normal(size=(15, 3)) * [10.0, 10.0, 30.0]
    model = minimax.AxisModel(p, np.array([1.0, 2.0, 0.0]), np.array([0.1, 0.0, 1.0]))
    axis = np.array([0.1, 0.0, 1.0]) / np.linalg.norm([0.1, 0.0, 1.0])
    rel = p - [1.0, 2.0, 0.0]
    exact = np.linalg.norm(rel - np.outer(rel @ axis, axis), axis=1)
    rho, jac = model.evaluate()
    np.testing.assert_allclose(rho, exact, rtol=1e-12)
    h = 1e-6
    for k in range(4):
        step = np.zeros(4)
        step[k] = h
        plus, _ = model.moved(step).evaluate()
        minus, _ = model.moved(-step).evaluate()
        np.testing.assert_allclose(jac[:, k], (plus - minus) / (2 * h), rtol=1e-5, atol=1e-6)


def test_sequential_lp_recovers_the_axis_of_points_on_one_cylinder():
    t = np.linspace(0.0, 2 * np.pi, 10, endpoint=False)
    ring = np.column_stack([8.0 * np.cos(t), 8.0 * np.sin(t)])
    p = np.column_stack([np.tile(ring, (3, 1)), np.repeat([-10.0, 0.0, 10.0], 10)])
    start = minimax.AxisModel(p, np.array([0.05, -0.03, 0.0]), np.array([0.002, 0.001, 1.0]))
    solution = minimax.sequential_lp(start, "zone", 20.0, "cylindricity")
    assert solution.status == ZoneStatus.OPTIMAL and solution.iterations >= 2
    assert np.ptp(solution.distances) < 1e-9
    assert abs(solution.model.direction[2]) == pytest.approx(1.0, abs=1e-12)


def test_partial_arc_has_no_inscribed_cylinder():
    t = np.linspace(0.0, 2 * np.pi / 3, 20)
    ring = np.column_stack([10 * np.cos(t), 10 * np.sin(t)])
    p = np.column_stack([np.tile(ring, (3, 1)), np.repeat([-5.0, 0.0, 5.0], 20)])
    with pytest.raises(FitError) as info:
        minimax.inscribed_cylinder(p)
    assert str(info.value) == (
        "the inscribed cylinder is unbounded: its radius grows without limit because the "
        "points do not surround a centre or axis (a partial arc or surface?)"
    )


def test_normal_with_2d_points_and_coplanar_sphere_points_are_refused():
    with pytest.raises(FitError) as info:
        minimax.roundness(np.random.default_rng(0).random((10, 2)), normal=[0, 0, 1])
    assert str(info.value) == "normal applies to points in 3-D; 2-D points lie in their plane"
    flat = np.column_stack([np.random.default_rng(1).random((10, 2)), np.zeros(10)])
    with pytest.raises(FitError) as info:
        minimax.sphericity(flat)
    assert str(info.value).startswith("sphericity: the 10 points are coplanar")


def test_an_iterative_zone_counts_its_linear_programs():
    # an ellipse-like profile: the minimum-zone centre needs at least one LP step
    t = np.linspace(0.0, 2.0 * np.pi, 24, endpoint=False)
    r = 10.0 + 0.01 * np.cos(2 * t) + 0.004 * np.sin(3 * t)
    zone = minimax.roundness(np.column_stack([r * np.cos(t), r * np.sin(t)]))
    assert zone.converged and type(zone.iterations) is int and zone.iterations >= 1
