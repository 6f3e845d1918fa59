"""Tests for mtmetrology.fitting.axial (least-squares cylinders and cones).

The exact recovery of posed elements and the mpmath references are in
test_least_squares.py (the public entry point); here: the sign of the residuals, the
starting direction, the sense of the cone axis, invariances and refusals.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mtmetrology.fitting.axial import fit_cone, fit_cylinder
from mtmetrology.fitting.validation import FitError

DELTA = 0.001  # mm


def _alternating_cylinder(radius=10.0):
    """Three sections of 8 points, radii alternating radius ± DELTA about the z axis."""
    t = np.arange(8) * np.pi / 4
    r = radius + DELTA * (-1.0) ** np.arange(8)
    ring = np.column_stack([r * np.cos(t), r * np.sin(t)])
    return np.column_stack([np.tile(ring, (3, 1)), np.repeat([-5.0, 0.0, 5.0], 8)])


def _cone_points(psi, z=(10.0, 20.0, 30.0), offset=0.0):
    """Sections of 8 points on the cone of apex 0, axis +z, moved by ``offset`` along the
    outward surface normal, alternating in sign."""
    t = np.arange(8) * np.pi / 4
    rows = []
    for zk in z:
        radial = np.column_stack([np.cos(t), np.sin(t), np.zeros(8)])
        normal = np.cos(psi) * radial - np.sin(psi) * np.array([0.0, 0.0, 1.0])
        surface = zk * np.tan(psi) * radial + [0.0, 0.0, zk]
        rows.append(surface + (offset * (-1.0) ** np.arange(8))[:, None] * normal)
    return np.vstack(rows)


def test_cylinder_residuals_are_positive_outside():
    """Points alternating ± DELTA about a cylinder: the fit is that cylinder, residual
    ρ_i − r is +DELTA for the points outside it, −DELTA for those inside."""
    fit = fit_cylinder(_alternating_cylinder())
    assert fit.element.radius == pytest.approx(10.0, abs=1e-12)
    np.testing.assert_allclose(
        fit.residuals, DELTA * np.tile((-1.0) ** np.arange(8), 3), atol=1e-12
    )
    assert fit.form_error == pytest.approx(2 * DELTA, abs=1e-12)
    assert fit.parameter_names == ("x0", "y0", "z0", "ax", "ay", "az", "r")


def test_cone_residuals_axis_sense_and_apex():
    psi = 0.3
    fit = fit_cone(_cone_points(psi, offset=DELTA))
    cone = fit.element
    assert cone.half_angle == pytest.approx(psi, abs=1e-10)
    np.testing.assert_allclose(cone.direction, [0.0, 0.0, 1.0], atol=1e-10)  # into the cone
    np.testing.assert_allclose(cone.apex, 0.0, atol=1e-8)
    np.testing.assert_allclose(
        fit.residuals, DELTA * np.tile((-1.0) ** np.arange(8), 3), atol=1e-10
    )


@pytest.mark.parametrize("hint", [[0.0, 0.0, 1.0], [0.0, 0.05, -1.0]])
def test_cone_direction_hint_of_either_sense_gives_the_axis_into_the_cone(hint):
    psi = 0.6
    points = _cone_points(psi, z=(12.0, 15.0))[::2]  # 8 points on a short frustum
    fit = fit_cone(points, direction=hint)
    np.testing.assert_allclose(fit.element.direction, [0.0, 0.0, 1.0], atol=1e-9)
    assert fit.element.half_angle == pytest.approx(psi, abs=1e-9)


def test_cylinder_direction_hint_and_its_refusal():
    rot = Rotation.from_euler("xyz", [0.3, -0.4, 1.2]).as_matrix()
    points = _alternating_cylinder() @ rot.T + [100.0, -50.0, 20.0]
    free = fit_cylinder(points)
    hinted = fit_cylinder(points, direction=rot[:, 2] + [0.02, 0.0, 0.0])
    assert abs(hinted.element.direction @ rot[:, 2]) == pytest.approx(1.0, abs=1e-12)
    assert hinted.element.radius == pytest.approx(free.element.radius, abs=1e-12)
    with pytest.raises(FitError) as info:
        fit_cylinder(points, direction=[0.0, np.nan, 1.0])
    assert str(info.value) == (
        "cylinder: direction must be a finite non-zero 3-vector, got array([ 0., nan,  1.])"
    )


def test_cylinder_is_invariant_under_permutation_and_rigid_motion():
    rng = np.random.default_rng(8)
    points = _alternating_cylinder() + rng.normal(scale=2e-4, size=(24, 3))
    base = fit_cylinder(points)
    shuffled = fit_cylinder(points[rng.permutation(24)])
    rot = Rotation.from_euler("zyx", [0.5, 0.2, -0.7]).as_matrix()
    moved = fit_cylinder(points @ rot.T + [7.0, 8.0, 9.0])
    for other in (shuffled, moved):
        assert other.element.radius == pytest.approx(base.element.radius, abs=1e-10)
        assert other.form_error == pytest.approx(base.form_error, abs=1e-10)
    direction = rot @ base.element.direction
    assert abs(moved.element.direction @ direction) == pytest.approx(1.0, abs=1e-12)


def test_too_few_and_coplanar_points_are_refused():
    with pytest.raises(FitError) as info:
        fit_cylinder(np.random.default_rng(0).random((4, 3)))
    assert (
        str(info.value) == "cylinder: 4 points are fewer than the 5 needed to determine the element"
    )
    flat = np.column_stack([np.random.default_rng(1).random((10, 2)), np.zeros(10)])
    with pytest.raises(FitError) as info:
        fit_cone(flat)
    assert str(info.value).startswith("cone: the 10 points are coplanar")
    assert str(info.value).endswith("; a cone needs points off one plane")
