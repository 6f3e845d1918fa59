"""Tests of mtmetrology.fitting.probe (probe-tip compensation)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mtmetrology.fitting.elements import Circle, Cone, Cylinder, Line, Plane, Sphere
from mtmetrology.fitting.least_squares import fit_circle, fit_cone, fit_cylinder, fit_plane
from mtmetrology.fitting.probe import (
    compensate,
    compensate_points,
    effective_tip_diameter,
    surface_normals,
)

D_CAL = 19.05  # mm, calibrated precision sphere (seed 000, digest 000 §2.2)
D_TIP = 5.925  # mm, published effective tip diameter (digest 000 §2.1, §3.12)


def _five_point_pattern(radius, centre, tilt=0.4):
    """The usual five-point sphere probing: the pole and four points 90° apart at a
    latitude of ``tilt`` rad above the equator (B = C = 0, stylus along −z)."""
    ring = [
        [math.cos(a) * math.cos(tilt), math.sin(a) * math.cos(tilt), math.sin(tilt)]
        for a in (0.0, math.pi / 2, math.pi, 3 * math.pi / 2)
    ]
    return np.asarray(centre) + radius * np.vstack([[0.0, 0.0, 1.0], ring])


def test_effective_tip_diameter_seed_000_is_5_925_mm():
    """Digest 000 §3.12: d_tip = 2 R_fit − D_cal from 5 points at B = C = 0; stylus
    centres on a sphere of radius (19.05 + 5.925)/2 give back 5.925 mm."""
    pts = _five_point_pattern((D_CAL + D_TIP) / 2, [312.5, -87.0, 140.25])
    cal = effective_tip_diameter(pts, D_CAL)
    assert cal.diameter == pytest.approx(D_TIP, abs=1e-9)
    assert cal.radius == pytest.approx(D_TIP / 2, abs=1e-9)
    assert cal.u == 0.0
    assert "5.9250 mm" in cal.message


def test_effective_tip_uncertainty_combines_fit_and_calibration():
    """u² = 4 u²(R_fit) + u²(D_cal): seed 000 U(D_cal) = 0.5 µm (k = 2) → 0.25 µm."""
    pts = _five_point_pattern((D_CAL + D_TIP) / 2, [0.0, 0.0, 0.0])
    only_cal = effective_tip_diameter(pts, D_CAL, u_calibrated=0.25e-3)
    assert only_cal.u == pytest.approx(0.25e-3, rel=1e-12)
    both = effective_tip_diameter(pts, D_CAL, u_calibrated=0.25e-3, sigma_points=1e-3)
    u_r2 = both.fit.parameter_covariance(1e-3)[3, 3]
    assert both.u == pytest.approx(math.sqrt(4 * u_r2 + 0.25e-3**2), rel=1e-12)
    assert both.u > only_cal.u


def test_effective_tip_diameter_refuses_points_inside_the_sphere():
    pts = _five_point_pattern(D_CAL / 2 - 1.0, [0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="not larger than the calibrated sphere"):
        effective_tip_diameter(pts, D_CAL)
    with pytest.raises(ValueError, match="calibrated_diameter"):
        effective_tip_diameter(pts, -1.0)


def _stylus_centres(surface, contacts, tip_radius, inside):
    """Stylus centres one tip radius from the surface contacts, on the probe's side."""
    sign = -1.0 if inside else 1.0
    return contacts + sign * tip_radius * surface_normals(surface, contacts)


@pytest.mark.parametrize("inside", [False, True])
def test_fit_then_compensate_recovers_the_surface_cylinder(inside):
    rng = np.random.default_rng(1)
    rot = Rotation.random(random_state=1).as_matrix()
    theta, z = rng.uniform(0, 2 * np.pi, 20), rng.uniform(-15, 15, 20)
    surface = Cylinder([10.0, 20.0, 30.0], rot[:, 2], 12.0)
    contacts = np.column_stack([12 * np.cos(theta), 12 * np.sin(theta), z]) @ rot.T + [10, 20, 30]
    stylus = _stylus_centres(surface, contacts, 3.0, inside)
    fitted = fit_cylinder(stylus).element
    assert fitted.radius == pytest.approx(12.0 + (-3.0 if inside else 3.0), abs=1e-9)
    recovered = compensate(fitted, 3.0, inside=inside)
    assert recovered.radius == pytest.approx(12.0, abs=1e-9)
    np.testing.assert_allclose(recovered.distances(contacts), 0.0, atol=1e-9)
    np.testing.assert_allclose(compensate_points(stylus, fitted, 3.0, inside), contacts, atol=1e-9)


@pytest.mark.parametrize("inside", [False, True])
def test_fit_then_compensate_recovers_the_surface_cone(inside):
    """Offsetting a cone along its normals keeps ψ and slides the apex by r / sin ψ."""
    rng = np.random.default_rng(2)
    psi = 0.5
    surface = Cone([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], psi)
    theta, z = rng.uniform(0, 2 * np.pi, 30), rng.uniform(10, 40, 30)
    r = z * np.tan(psi)
    contacts = np.column_stack([r * np.cos(theta), r * np.sin(theta), z])
    stylus = _stylus_centres(surface, contacts, 2.5, inside)
    fitted = fit_cone(stylus).element
    assert fitted.half_angle == pytest.approx(psi, abs=1e-9)
    recovered = compensate(fitted, 2.5, inside=inside)
    np.testing.assert_allclose(recovered.apex, [0.0, 0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(recovered.distances(contacts), 0.0, atol=1e-9)


def test_ring_gauge_and_plane_compensation():
    """A Ø 63.50 mm ring gauge probed from inside (digest 000 §2.2): R_fit + r_tip."""
    theta = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    r_fit = 63.5 / 2 - D_TIP / 2
    stylus = np.column_stack([r_fit * np.cos(theta), r_fit * np.sin(theta), np.zeros(12)])
    ring = compensate(fit_circle(stylus).element, D_TIP / 2, inside=True)
    assert 2 * ring.radius == pytest.approx(63.5, abs=1e-12)
    assert isinstance(ring, Circle) and ring.normal is not None
    # A face probed from +z: the stylus centres lie r_tip above the surface z = 5.
    face = np.column_stack([np.random.default_rng(3).uniform(-50, 50, (9, 2)), np.full(9, 8.0)])
    plane = fit_plane(face).element  # normal +z (largest component positive)
    surface = compensate(plane, 3.0)
    assert surface.distances(np.array([[0.0, 0.0, 5.0]]))[0] == pytest.approx(0.0, abs=1e-12)
    flipped = compensate(Plane(plane.point, -plane.normal), 3.0, inside=True)
    assert flipped.distances(np.array([[0.0, 0.0, 5.0]]))[0] == pytest.approx(0.0, abs=1e-12)


def test_sphere_compensation_outer_and_inner():
    ball = Sphere([1.0, 2.0, 3.0], (D_CAL + D_TIP) / 2)
    assert 2 * compensate(ball, D_TIP / 2).radius == pytest.approx(D_CAL, abs=1e-12)
    assert compensate(ball, D_TIP / 2, inside=True).radius == pytest.approx(ball.radius + D_TIP / 2)
    pts = ball.project(np.random.default_rng(4).normal(size=(6, 3)) + ball.centre)
    contacts = compensate_points(pts, ball, D_TIP / 2)
    np.testing.assert_allclose(np.linalg.norm(contacts - ball.centre, axis=1), D_CAL / 2)


@pytest.mark.parametrize(
    ("call", "pattern"),
    [
        (lambda: compensate(Sphere([0, 0, 0], 2.0), 3.0), "not smaller than the fitted radius"),
        (lambda: compensate(Sphere([0, 0, 0], 2.0), -0.1), "tip_radius"),
        (lambda: compensate(Line([0, 0, 0], [1, 0, 0]), 1.0), "no probe compensation"),
        (lambda: surface_normals(Line([0, 0, 0], [1, 0, 0]), [[1, 1, 1]]), "has no normal"),
        (lambda: surface_normals(Sphere([0, 0, 0], 1.0), [[0, 0, 0]]), "undefined"),
    ],
)
def test_invalid_compensation_is_refused(call, pattern):
    with pytest.raises(ValueError, match=pattern):
        call()
