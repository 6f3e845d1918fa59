"""Tests for mtmetrology.fitting.odr (what the least-squares fits share): the FitResult
record, the point sensitivities, the conditioning check, the choice between starts, the
messages and the algebraic starting circle/sphere."""

import math
from types import SimpleNamespace

import numpy as np
import pytest

from mtmetrology.fitting.elements import Plane, Sphere
from mtmetrology.fitting.least_squares import fit_line, fit_plane, fit_sphere
from mtmetrology.fitting.odr import (
    better_fit,
    check_conditioning,
    fit_message,
    hyper_fit,
    local_to_points,
    solve_distances,
)
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


@pytest.mark.parametrize("dim", [2, 3])
def test_hyper_fit_recovers_an_exact_circle_and_sphere(dim):
    rng = np.random.default_rng(dim)
    u = rng.normal(size=(9, dim))
    centre = np.arange(1.0, dim + 1.0)
    x = centre + 7.5 * u / np.linalg.norm(u, axis=1, keepdims=True)
    x_mean = x.mean(axis=0)
    c, r = hyper_fit(x - x_mean)
    np.testing.assert_allclose(c + x_mean, centre, atol=1e-10)
    assert r == pytest.approx(7.5, abs=1e-10)


def test_hyper_fit_refuses_collinear_points():
    with pytest.raises(FitError) as info:
        hyper_fit(np.column_stack([np.linspace(-1.0, 1.0, 5), np.zeros(5)]))
    assert str(info.value) == "the points lie on a line/plane: no finite circle/sphere"


def test_local_to_points_is_minus_the_pseudo_inverse_times_the_point_derivatives():
    rng = np.random.default_rng(5)
    j = rng.normal(size=(6, 2, 3))  # 6 points, 2 residuals each, 3 parameters
    g = rng.normal(size=(6, 2, 3))
    expected = np.zeros((3, 6, 3))
    pinv = np.linalg.pinv(j.reshape(12, 3))  # (3, 12)
    for i in range(6):
        for d in range(3):
            dd = np.zeros((6, 2))
            dd[i] = g[i, :, d]
            expected[:, i, d] = -pinv @ dd.reshape(12)
    np.testing.assert_allclose(local_to_points(j, g), expected, atol=1e-12)


def test_check_conditioning_refuses_dependent_columns():
    j = np.column_stack([np.arange(5.0), 2 * np.arange(5.0), np.ones(5)])
    with pytest.raises(FitError) as info:
        check_conditioning("circle", j, "a, b, r")
    assert str(info.value).startswith(
        "circle: the parameters (a, b, r) are not determined by these points "
        "(Jacobian condition number "
    )
    check_conditioning("circle", np.eye(3), "a, b, r")  # well conditioned: no error


def test_better_fit_prefers_converged_then_clearly_lower_cost():
    def run(success, cost):
        return SimpleNamespace(success=success, cost=cost)

    assert better_fit(run(False, 5.0), None)
    assert better_fit(run(True, 9.0), run(False, 1.0))
    assert not better_fit(run(False, 0.1), run(True, 1.0))
    assert better_fit(run(True, 0.5), run(True, 1.0))
    assert not better_fit(run(True, 1.0 - 1e-12), run(True, 1.0))  # a tie keeps the first


def test_fit_message_names_the_stop_and_the_rms():
    assert fit_message("plane", None, 0.00123) == "plane: closed-form SVD fit (rms 0.00123 mm)"
    solve = SimpleNamespace(message="step below tolerance", nit=4, success=True)
    assert fit_message("sphere", solve, 0.5) == (
        "sphere: step below tolerance after 4 iterations (rms 0.5 mm)"
    )
    solve = SimpleNamespace(message="iteration limit", nit=200, success=False)
    assert fit_message("cone", solve, 1.0) == (
        "cone: iteration limit after 200 iterations (rms 1 mm); the result is the best "
        "point reached"
    )


def test_solve_distances_finds_the_centre_of_a_circle_of_known_radius():
    t = np.linspace(0.0, 2 * np.pi, 7, endpoint=False)
    p = np.column_stack([3.0 + 5.0 * np.cos(t), -1.0 + 5.0 * np.sin(t)])

    def evaluate(c):
        diff = p - c
        rho = np.linalg.norm(diff, axis=1)
        return rho - 5.0, -diff / rho[:, None]

    result = solve_distances(evaluate, lambda c, step: c + step, np.array([2.5, -0.5]), 10.0)
    assert result.success
    np.testing.assert_allclose(result.x, [3.0, -1.0], atol=1e-11)


def test_fit_result_parameter_views_follow_the_element():
    fit = fit_plane([[0.0, 0.0, 2.0], [1.0, 0.0, 2.0], [0.0, 1.0, 2.0], [1.0, 1.0, 2.0]])
    assert fit.parameter_names == Plane.parameter_names
    assert fit.parameter_jacobian.shape == (len(Plane.parameter_names), 4, 3)
    assert fit.residual_jacobian().shape == (4, 4, 3)
    assert Sphere.parameter_names == fit_sphere(OCTAHEDRON).parameter_names
