"""Closed-form signatures of the ballbar observation model, each sign pinned.

Test: XY plane, R = 100 mm, centre (x_c, y_c) = (10, 20) mm, feed 1200 mm/min, on a
three-axis XFYZ machine (monomial errors, zero offsets, tool at the Y/Z reference point).
"""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.ballbar.diagnose import simulate
from mtmetrology.ballbar.model import BallbarProblem, plane_model
from mtmetrology.ballbar.records import BallbarConditions, nominal_test
from mtmetrology.kinematics.machine import Machine

R, XC, YC, FEED = 100.0, 10.0, 20.0, 1200.0
CONDITIONS = BallbarConditions("XY", R, FEED, np.array([XC, YC, 0.0]), name="xy")
# second order in the errors: (5 µm)²/(2R) ≈ 1e-7 mm
TOL = 1e-6


@pytest.fixture(scope="module")
def machine():
    return Machine.from_topology("WXFYZT")


@pytest.fixture(scope="module")
def test():
    return nominal_test(CONDITIONS, 360)


def _reading(machine, test, truth):
    return simulate(machine, [test], truth)[0].reading


def test_squareness_alone_is_an_ellipse_at_45_and_135(machine, test):
    eps = 50e-6  # E_C0Y > 0: Y tilted about +Z, the tool deviates by −ε·y along X
    th = test.angle
    expected = -eps * R / 2 * np.sin(2 * th) - eps * YC * np.cos(th)
    np.testing.assert_allclose(_reading(machine, test, {"E_C0Y": eps}), expected, atol=TOL)


def test_scale_mismatch_alone_is_an_ellipse_along_the_axes(machine, test):
    s = 40e-6  # E_XX1 > 0: the tool at x(1 + s)
    th = test.angle
    expected = s * (XC + R * np.cos(th)) * np.cos(th)
    np.testing.assert_allclose(_reading(machine, test, {"E_XX1": s}), expected, atol=TOL)


def test_backlash_alone_steps_at_the_quadrant_crossings(machine, test):
    b = 3e-3  # E_XXb > 0: the tool displaced by +b in the sense of motion of X
    ell = _reading(machine, test, {"E_XXb": b})
    th, d = test.angle, test.direction
    sense_x = -np.sign(np.sin(th + d * 1e-9)) * d
    np.testing.assert_allclose(ell, b * sense_x * np.cos(th), atol=TOL)
    ccw = d == 1
    # counter-clockwise: 359° before the crossing, 0° just after: a step of −2b
    at = {round(np.degrees(a)): v for a, v in zip(th[ccw], ell[ccw], strict=True)}
    assert at[359] - b * np.cos(np.radians(359)) == pytest.approx(0.0, abs=TOL)
    assert at[0] == pytest.approx(-b, abs=TOL)


def test_servo_mismatch_flips_with_direction(machine, test):
    tau = 0.2e-3  # s: Y lags X; δ = −τ v_y (4 µm at 20 mm/s)
    ell = _reading(machine, test, {"servo_mismatch_XY": tau})
    v = FEED / 60.0
    expected = -tau * test.direction * v * np.sin(test.angle) * np.cos(test.angle)
    np.testing.assert_allclose(ell, expected, atol=TOL)


def test_reversal_spike_is_outward_and_decays(machine, test):
    a = 4e-3
    ell = _reading(machine, test, {"reversal_spike_X": a})
    ccw = test.direction == 1
    th = test.angle[ccw]
    # counter-clockwise: X reverses at 0° and 180°; 3° decay arc
    since = np.mod(th, np.pi)
    expected = a * np.exp(-since / np.radians(3.0)) * np.abs(np.cos(th))
    np.testing.assert_allclose(ell[ccw], expected, atol=TOL)
    assert ell[ccw][0] == pytest.approx(a, abs=TOL)


def test_jacobian_matches_finite_differences(machine, test):
    m = machine.with_parameters(plane_model(machine, "XY"))
    problem = BallbarProblem(m, [test], length_calibrated=False, sigma=1e-3)
    x = problem.initial() + 1e-5
    _, jac = problem.evaluate(x)
    h = 1e-7
    for j in range(len(problem.names)):
        e = np.zeros_like(x)
        e[j] = h
        fd = (problem.evaluate(x + e, False) - problem.evaluate(x - e, False)) / (2 * h)
        np.testing.assert_allclose(jac[:, j], fd, rtol=1e-5, atol=1e-3)


def test_plane_models_follow_the_preset_names():
    m = Machine.load("five-axis-wcbxfzyst")
    assert plane_model(m, "YZ")[2] == "E_A0Y"
    assert plane_model(m, "ZX")[2] == "E_B0Z"
