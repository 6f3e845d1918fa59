"""The identification engine's adequacy rule in the tracker calibration (issue 30): noise
larger than the noise model scales the covariance of θ and the pose by s², the option
keeps it; the document records the test and the residual RMS by tool."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mtmetrology.kinematics.tracker import TrackerNoise
from mtmetrology.tracker import TrackerCalibration, calibrate, simulate
from mtmetrology.units import to_internal

from .conftest import THREE_TOOLS

MODEL = TrackerNoise()  # the paper's noise model, the weights of the calibration
LOUD = TrackerNoise(
    u_range_constant=3 * MODEL.u_range_constant,
    u_range_per_length=3 * MODEL.u_range_per_length,
    u_angle=3 * MODEL.u_angle,
    u_angle_spread=0.0,
)


def _truth(machine, seed):
    rng = np.random.default_rng(seed)
    um = np.array([u == "µm" for u in machine.parameter_units])
    return rng.normal(size=machine.n_params) * np.where(um, to_internal(3.0, "µm"), 5e-6)


def test_noise_three_times_the_model_scales_theta_and_pose_covariance(machine, mesh, pose):
    meas = simulate(machine, _truth(machine, 1), pose, mesh, THREE_TOOLS, noise=LOUD, seed=2)
    scaled = calibrate(machine, meas, noise=MODEL)
    kept = calibrate(machine, meas, noise=MODEL, adequacy="a-priori")
    a = scaled.adequacy
    assert a.significant and a.scaled and a.factor > 4.0
    assert not kept.adequacy.scaled and kept.adequacy.factor == 1.0
    np.testing.assert_allclose(scaled.parameters.values, kept.parameters.values, rtol=1e-12)
    np.testing.assert_allclose(
        scaled.parameters.covariance, a.factor * kept.parameters.covariance, rtol=1e-10
    )
    np.testing.assert_allclose(scaled.pose_covariance, a.factor * kept.pose_covariance, rtol=1e-10)
    assert a.message in scaled.summary()
    doc = json.loads(json.dumps(scaled.to_dict()))
    assert doc["adequacy"]["scaled"] and doc["adequacy"]["factor"] == pytest.approx(a.factor)
    tools = doc["residual_patterns"]["tool"]
    assert [g["n"] for g in tools] == [len(mesh)] * 3
    assert all(g["rms_weighted"] > 1.5 for g in tools)
    back = TrackerCalibration.from_dict(doc, machine)
    assert back.adequacy == a and back.residual_patterns == doc["residual_patterns"]


def test_noise_as_modelled_leaves_the_covariance_a_priori(machine, mesh, pose):
    """The simulation draws the angle level once per test (N(20, 3) µrad) and the model
    weights with its effective level: the test passes at this seed and nothing is scaled."""
    meas = simulate(machine, _truth(machine, 3), pose, mesh, THREE_TOOLS, noise=MODEL, seed=4)
    cal = calibrate(machine, meas, noise=MODEL)
    assert cal.adequacy.p_value >= 0.01 and not cal.adequacy.scaled
    assert cal.adequacy.variance_factor == pytest.approx(cal.variance_factor, rel=1e-12)
