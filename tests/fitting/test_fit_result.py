"""The FitResult record: counts, parameter views, covariance refusals, and what a closed
form and an iterative fit report."""

import math

import numpy as np
import pytest

from mtmetrology.fitting.elements import Cone, Line, Plane, Sphere
from mtmetrology.fitting.least_squares import fit_cone, fit_line, fit_plane, fit_sphere
from mtmetrology.fitting.validation import FitError
from mtmetrology.optimize import Status

# the six points (±R, 0, 0), (0, ±R, 0), (0, 0, ±R) on a sphere of radius 10 about (1, 2, 3)
OCTAHEDRON = np.array([1.0, 2.0, 3.0]) + 10.0 * np.vstack([np.eye(3), -np.eye(3)])


def test_a_closed_form_fit_reports_exact_and_no_evaluations():
    pts = [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0], [1.0, 1.0, 1.0]]
    fit = fit_plane(pts)
    assert (fit.status, fit.nit, fit.nfev, fit.success) == (Status.EXACT, 0, 0, True)
    assert fit.parameter_names == Plane.parameter_names
    np.testing.assert_array_equal(fit.parameters, fit.element.parameters)
    assert fit.rms == 0.0 and fit.form_error == 0.0


def test_an_iterative_fit_counts_its_evaluations():
    fit = fit_sphere(OCTAHEDRON)
    assert fit.success and fit.status in (Status.STEP_TOLERANCE, Status.ROUNDING_LEVEL)
    assert fit.nit >= 1 and fit.nfev >= fit.nit
    assert fit.parameter_names == Sphere.parameter_names
    np.testing.assert_allclose(fit.parameters, [1.0, 2.0, 3.0, 10.0], atol=1e-12)


def test_parameter_covariance_of_the_octahedron():
    # For the six axis points, dR/dP_i = n_i/6 (mean of the radial unit vectors), and each
    # centre coordinate is the mean of its two opposite points: u²(x0) = 2σ²/4 = σ²/2.
    sigma = 0.002
    cov = fit_sphere(OCTAHEDRON).parameter_covariance(sigma)
    np.testing.assert_allclose(np.diag(cov), [sigma**2 / 2] * 3 + [sigma**2 / 6], rtol=1e-9)
    np.testing.assert_array_equal(fit_sphere(OCTAHEDRON).parameter_covariance(0.0), 0.0)


@pytest.mark.parametrize("sigma", [-1e-3, math.inf, math.nan])
def test_parameter_covariance_refuses_a_bad_sigma(sigma):
    with pytest.raises(ValueError) as err:
        fit_sphere(OCTAHEDRON).parameter_covariance(sigma)
    assert str(err.value) == f"sigma must be a non-negative finite number, got {sigma!r}"


def test_points_on_a_spatial_line_have_finite_sensitivities():
    # every residual is 0, so every radial direction is undefined: the residuals'
    # sensitivities are still finite (the undefined directions get weight 0)
    fit = fit_line([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [3.0, 0.0, 0.0]])
    assert fit.form_error == 0.0
    assert np.all(np.isfinite(fit.parameter_jacobian))
    assert np.all(np.isfinite(fit.residual_jacobian()))


@pytest.mark.parametrize(
    ("build", "message"),
    [
        (
            lambda: Cone(apex=[1.0, 2.0], direction=[0.0, 0.0, 1.0], half_angle=0.5),
            "cone apex must be a vector of length 3, got shape (2,)",
        ),
        (
            lambda: Line(point=[0.0, 0.0, 0.0], direction=[0.0, 0.0, 0.0]),
            "line direction must be a non-zero vector",
        ),
        (
            lambda: Plane(point=[0.0, 0.0], normal=[0.0, 0.0, 1.0]),
            "plane point must be a vector of length 3, got shape (2,)",
        ),
        (
            lambda: fit_cone(
                [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [2, 1, 0], [3, 3, 0], [5, 1, 0]]
            ),
            "cone: the 7 points are coplanar (relative singular value 0.0e+00 of the centred "
            "points); a cone needs points off one plane",
        ),
    ],
)
def test_element_refusals_name_the_element_and_its_part(build, message):
    with pytest.raises(ValueError) as err:
        build()
    assert str(err.value) == message


def test_a_cone_stores_its_apex_as_a_float_array():
    cone = Cone(apex=[1, 2, 3], direction=[0, 0, 2], half_angle=0.5)
    assert isinstance(cone.apex, np.ndarray) and cone.apex.dtype == float
    np.testing.assert_array_equal(cone.parameters, [1.0, 2.0, 3.0, 0.0, 0.0, 1.0, 0.5])


@pytest.mark.parametrize(
    ("radius", "message"),
    [
        (
            10.0,
            "sphere (known radius): the 4 points are coplanar (relative singular value "
            "0.0e+00 of the centred points); the mirror-image centres cannot be told apart",
        ),
        (
            None,
            "sphere: the 4 points are coplanar (relative singular value 0.0e+00 of the "
            "centred points); a sphere needs points off one plane (give the radius only if "
            "they are not)",
        ),
        (-1.0, "sphere (known radius): radius must be a positive finite number, got -1.0"),
    ],
)
def test_sphere_refusals_say_which_fit(radius, message):
    ring = [[10.0, 0.0, 0.0], [0.0, 10.0, 0.0], [-10.0, 0.0, 0.0], [0.0, -10.0, 0.0]]
    with pytest.raises(FitError) as err:
        fit_sphere(ring, radius=radius)
    assert str(err.value) == message
