"""Surface normals of the fitted elements (the offset directions of probe compensation):
exact unit vectors for points of known position, and the refusals."""

import math

import numpy as np
import pytest

from mtmetrology.fitting.elements import Circle, Cone, Cylinder, Line, Sphere
from mtmetrology.fitting.probe import compensate_points, effective_tip_diameter, surface_normals
from mtmetrology.fitting.validation import FitError


def test_sphere_normals_point_away_from_the_centre():
    sphere = Sphere(centre=[1.0, 2.0, 3.0], radius=5.0)
    points = [[4.0, 6.0, 3.0], [1.0, 2.0, -2.0]]
    np.testing.assert_allclose(
        surface_normals(sphere, points), [[0.6, 0.8, 0.0], [0.0, 0.0, -1.0]], atol=1e-15
    )


def test_a_circle_in_space_has_normals_in_its_plane():
    # the out-of-plane part of the point (z = 7 above the plane z = 0) is removed
    circle = Circle(centre=[0.0, 0.0, 0.0], radius=5.0, normal=[0.0, 0.0, 1.0])
    np.testing.assert_allclose(
        surface_normals(circle, [[3.0, 4.0, 7.0]]), [[0.6, 0.8, 0.0]], atol=1e-15
    )
    flat = Circle(centre=[1.0, 1.0], radius=2.0)
    np.testing.assert_allclose(surface_normals(flat, [[1.0, -2.0]]), [[0.0, -1.0]], atol=1e-15)


def test_cylinder_and_cone_normals():
    cyl = Cylinder(point=[0.0, 0.0, 0.0], direction=[0.0, 0.0, 1.0], radius=5.0)
    np.testing.assert_allclose(
        surface_normals(cyl, [[0.0, 5.0, 40.0]]), [[0.0, 1.0, 0.0]], atol=1e-15
    )
    psi = math.pi / 6
    cone = Cone(apex=[0.0, 0.0, 0.0], direction=[0.0, 0.0, 1.0], half_angle=psi)
    # the outward normal of the nappe: (cos ψ) radial − (sin ψ) axial
    np.testing.assert_allclose(
        surface_normals(cone, [[2.0, 0.0, 10.0]]),
        [[math.cos(psi), 0.0, -math.sin(psi)]],
        atol=1e-15,
    )


def test_compensated_points_lie_one_tip_radius_inwards_or_outwards():
    sphere = Sphere(centre=[0.0, 0.0, 0.0], radius=10.0)
    p = [[0.0, 0.0, 13.0]]
    np.testing.assert_allclose(compensate_points(p, sphere, 3.0), [[0.0, 0.0, 10.0]])
    np.testing.assert_allclose(compensate_points(p, sphere, 3.0, inside=True), [[0, 0, 16.0]])


def test_undefined_normals_are_refused():
    with pytest.raises(FitError) as err:
        surface_normals(Sphere(centre=[0.0, 0.0, 0.0], radius=1.0), [[0.0, 0.0, 0.0]])
    assert str(err.value) == "a point lies on the centre or axis: its normal is undefined"
    line = Line(point=[0.0, 0.0, 0.0], direction=[1.0, 0.0, 0.0])
    with pytest.raises(FitError) as err:
        surface_normals(line, [[1.0, 1.0, 1.0]])
    assert str(err.value) == "a Line of dimension 3 has no normal"


def _sphere_points(radius: float) -> np.ndarray:
    return radius * np.array(
        [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0.6, 0, 0.8]], dtype=float
    )


def test_tip_calibration_without_point_noise_carries_the_calibration_uncertainty():
    # stylus centres on a sphere of radius (19.05 + 5.925)/2: d_tip = 5.925 mm exactly
    cal = effective_tip_diameter(_sphere_points((19.05 + 5.925) / 2), 19.05, 0.25e-3)
    assert cal.diameter == pytest.approx(5.925, abs=1e-12)
    assert cal.u == 0.25e-3  # u(R_fit) is 0 without sigma_points


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"calibrated_diameter": 0.0}, "calibrated_diameter must be a positive length, got 0.0"),
        ({"u_calibrated": -1.0}, "u_calibrated must be >= 0 mm, got -1.0"),
        ({"sigma_points": -1.0}, "sigma_points must be >= 0 mm, got -1.0"),
        ({"sigma_points": math.nan}, "sigma_points must be >= 0 mm, got nan"),
    ],
)
def test_tip_calibration_refusals(kwargs, message):
    args = {"calibrated_diameter": 19.05, **kwargs}
    with pytest.raises(FitError) as err:
        effective_tip_diameter(_sphere_points(12.5), **args)
    assert str(err.value) == message
