"""Ballbar tests identify together with the laser runs: the XY-plane calibration and an
ISO 230-2 run of X combined by generalised least squares
(:func:`~mtmetrology.identification.combine.combine_parameter_sets`) on a virtual machine
whose errors both models hold exactly."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from mtmetrology.ballbar.diagnose import diagnose, simulate
from mtmetrology.ballbar.records import BallbarConditions, nominal_test
from mtmetrology.identification.combine import combine_parameter_sets
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.positioning.identify import axis_machine
from mtmetrology.positioning.simulate import iso_targets, simulate_test
from mtmetrology.positioning.workflow import analyse

#: internal units (mm, rad): scale and reversal of X seen by both, the rest by the ballbar
TRUTH = {"E_XX1": 8e-3, "E_XXb": 1.5e-3, "E_YY1": -5e-3, "E_C0Y": 20e-6, "E_YYb": -1e-3}
SHARED = ("E_XX1", "E_XXb")
REPEATS = 40


def _u(pset: ParameterSet, name: str) -> float:
    return float(pset.standard_uncertainty[pset.names.index(name)])


def _value(pset: ParameterSet, name: str) -> float:
    return float(pset.values[pset.names.index(name)])


@pytest.fixture(scope="module")
def virtual():
    m = Machine.load("three-axis-xfyz")
    sub = axis_machine(m, "X")  # E_XX1..3 and E_XXb in the model's basis
    laser_truth = ParameterSet(
        sub.parameter_names,
        np.array([TRUTH.get(n, 0.0) for n in sub.parameter_names]),
        sub.parameter_units,
        machine=m.name,
    )
    centre = np.array([1000.0, 300.0, 300.0])
    tests = [
        nominal_test(BallbarConditions("XY", r, 1000.0, centre, name=f"XY{r:g}"), 360)
        for r in (100.0, 150.0)
    ]
    return m, laser_truth, tests


def _one(virtual, seed: int):
    m, laser_truth, tests = virtual
    run = simulate_test(
        m, laser_truth, "X", iso_targets(800, 1200, 21, seed=seed), sigma_mm=0.0008, seed=seed
    )
    laser = analyse(run, machine=m).parameter_set
    ballbar = diagnose(m, simulate(m, tests, TRUTH, sigma=1e-3, seed=1000 + seed))
    return laser, ballbar.parameter_set()


def test_combining_reduces_u_of_the_shared_terms(virtual):
    laser, ballbar = _one(virtual, 0)
    combined = combine_parameter_sets(laser, ballbar)
    for name in SHARED:
        assert _u(combined, name) < min(_u(laser, name), _u(ballbar, name)), name
    # the terms one set holds are carried: E_XX2 (laser only), E_C0Y (ballbar only)
    assert {"E_XX2", "E_C0Y"} <= set(combined.names)


@pytest.mark.slow
def test_combined_estimate_within_2u_of_truth_at_the_expected_rate(virtual):
    hits = []
    for seed in range(REPEATS):
        combined = combine_parameter_sets(*_one(virtual, seed))
        hits += [
            abs(_value(combined, n) - TRUTH[n]) <= 2 * _u(combined, n) for n in (*SHARED, "E_C0Y")
        ]
    # fewer hits than the 1 % quantile of Binomial(n, 0.9545) fails
    floor = stats.binom.ppf(0.01, len(hits), 0.9545)
    assert sum(hits) >= floor, (sum(hits), len(hits))
