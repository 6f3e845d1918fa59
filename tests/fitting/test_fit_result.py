"""The FitResult record: counts, parameter views, covariance refusals, and what a closed
form and an iterative fit report."""

import math

import numpy as np
import pytest

from mtmetrology.fitting.elements import Plane, Sphere
from mtmetrology.fitting.least_squares import fit_plane, fit_sphere
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
