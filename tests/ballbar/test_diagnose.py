"""Ballbar diagnosis as identification: exact recovery, rank advice, coverage over virtual tests."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from mtmetrology.ballbar.diagnose import (
    diagnose,
    diagnose_many,
    model_machine,
    simulate,
)
from mtmetrology.ballbar.model import BallbarProblem
from mtmetrology.ballbar.records import BallbarConditions, nominal_test
from mtmetrology.errors import RankDeficientError
from mtmetrology.kinematics.machine import Machine

CENTRE = np.array([10.0, 20.0, 30.0])


def _test(plane="XY", radius=100.0, n=360):
    return nominal_test(
        BallbarConditions(plane, radius, 1000.0, CENTRE, name=f"{plane}{radius:g}"), n
    )


@pytest.fixture(scope="module")
def machine():
    return Machine.from_topology("WXFYZT")


@pytest.mark.parametrize(
    "truth",
    [
        {"E_C0Y": 30e-6},  # squareness alone
        {"E_XX1": 25e-6},  # scale alone
        {"E_XXb": 2e-3, "E_YYb": -1e-3},  # backlash alone
        {"servo_mismatch_XY": 0.5e-3, "reversal_spike_Y": 2e-3},
    ],
)
def test_signature_alone_recovered_exactly(machine, truth):
    sim = simulate(machine, [_test()], truth)
    found = diagnose(machine, sim, sigma=1e-3)
    for name in found.names:
        if name.startswith("pivot"):
            continue
        assert found.value(name) == pytest.approx(truth.get(name, 0.0), abs=1e-12), name


def test_three_planes_two_radii_identify_together(machine):
    tests = [_test(p, r, 180) for p in ("XY", "YZ", "ZX") for r in (100.0, 150.0)]
    truth = {
        "E_C0Y": 20e-6,
        "E_B0Z": -15e-6,
        "E_A0Z": 5e-6,
        "E_XX1": 30e-6,
        "E_YY1": -10e-6,
        "E_ZZ1": 12e-6,
        "E_ZY2": 1e-7,
        "E_XXb": 2e-3,
        "E_ZZb": 1e-3,
        "servo_mismatch_ZX": -0.5e-3,
        "reversal_spike_Z": 3e-3,
        "length offset": 4e-3,
    }
    found = diagnose(machine, simulate(machine, tests, truth), length_calibrated=False)
    assert found.identification.diagnostics.full_rank
    for name, value in truth.items():
        assert found.value(name) == pytest.approx(value, abs=1e-12), name


def test_one_radius_cannot_separate_scale_from_the_bar_length(machine):
    with pytest.raises(RankDeficientError) as err:
        diagnose(machine, [_test()], length_calibrated=False)
    (group,) = err.value.confounded
    assert {"E_XX1", "E_YY1", "length offset"} <= set(group)
    found = diagnose(machine, [_test()], length_calibrated=False, minimum_norm=True)
    # another plane at the same radius leaves the isotropic scale ~ length; another radius
    # separates it
    assert found.advice == ["the XY plane at radius 150 mm"]
    both = diagnose(machine, [_test(), _test(radius=150.0)], length_calibrated=False)
    assert both.identification.diagnostics.full_rank


def test_document_fields(machine):
    sim = simulate(machine, [_test()], {"E_C0Y": 30e-6}, sigma=1e-3, seed=3)
    doc = diagnose(machine, sim).to_dict()
    assert (doc["kind"], doc["machine"], doc["category"]) == (
        "iso230-4-calibration",
        "WXFYZT",
        "calibration",
    )
    row = next(p for p in doc["estimates"] if p["name"] == "E_C0Y")
    assert row["unit"] == "µrad" and row["k"] == 2.0 and row["U"] == 2.0 * row["u"]
    assert abs(row["value"] - 30.0) < 3 * row["u"]
    assert set(doc["tests"][0]["iso230_4"]["circular_deviation_G"]) == {"ccw", "cw"}


def test_batched_uncertainty_equals_the_single_identification(machine):
    test = _test()
    sim = simulate(machine, [test], {"E_C0Y": 30e-6, "E_XXb": 1e-3}, sigma=1e-3, seed=5)
    one = diagnose(machine, sim)
    problem = BallbarProblem(model_machine(machine, [test]), [test], sigma=1e-3)
    many = diagnose_many(problem, sim[0].reading[None])
    for i, name in enumerate(problem.names):
        # the chord's fixed point differs from Gauss–Newton's at second order in the errors
        assert abs(many.estimate[0, i] - one.value(name)) < 1e-3 * one.u(name), name
        assert many.u[0, i] == pytest.approx(one.u(name), rel=1e-3), name


def test_coverage_of_2u_over_repeated_virtual_tests(machine):
    """200 virtual tests, noise 1 µm: each parameter within 2u of the truth at the normal
    rate 95.45 % (ν ≈ 700), inside the binomial 0.05 % acceptance interval."""
    test = _test(n=360)
    truth = {
        "E_C0Y": 20e-6,
        "E_XX1": 30e-6,
        "E_YY1": -10e-6,
        "E_XXb": 2e-3,
        "servo_mismatch_XY": 1e-3,
        "reversal_spike_X": 3e-3,
    }
    clean = simulate(machine, [test], truth)[0].reading
    k_tests = 200
    noise = np.random.default_rng(20261128).normal(0.0, 1e-3, (k_tests, clean.size))
    problem = BallbarProblem(model_machine(machine, [test]), [test], sigma=1e-3)
    found = diagnose_many(problem, clean + noise)
    assert np.all(found.status > 0)
    p = stats.norm.cdf(2.0) - stats.norm.cdf(-2.0)
    low, high = stats.binom.interval(0.999, k_tests, p)
    for i, name in enumerate(problem.names):
        if name.startswith("pivot"):
            continue
        inside = np.abs(found.estimate[:, i] - truth.get(name, 0.0)) <= 2.0 * found.u[:, i]
        assert low <= inside.sum() <= high, (name, inside.sum())
