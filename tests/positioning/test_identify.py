"""E_XX and E_XXb of the tested axis through the identification engine: exact at zero noise,
their 2u intervals cover the truth at the expected rate over many virtual tests."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.positioning.identify import axis_machine, identify_axis
from mtmetrology.positioning.simulate import iso_targets, simulate_test


@pytest.fixture(scope="module")
def setup():
    m = Machine.load("three-axis-xfyz")
    sub = axis_machine(m, "Y")
    truth = ParameterSet(
        sub.parameter_names, np.array([-0.008, 0.005, 0.002, -0.0015]), sub.parameter_units,
        machine=m.name,
    )  # fmt: skip
    return m, truth, iso_targets(100, 500, 11, seed=2)


def test_zero_noise_recovers_the_truth(setup):
    m, truth, targets = setup
    test = simulate_test(m, truth, "Y", targets, sigma_mm=0.0, seed=1)
    pset, info = identify_axis(m, "Y", targets, test.deviations)
    assert pset.names == ("E_YY1", "E_YY2", "E_YY3", "E_YYb")
    np.testing.assert_allclose(pset.values, truth.values, rtol=0, atol=1e-12)
    assert info["rms_residual_um"] < 1e-9 and info["max_mean_misfit_um"] < 1e-9


def test_a_periodic_error_the_cubic_cannot_follow_shows_as_misfit(setup):
    m, truth, targets = setup
    test = simulate_test(m, truth, "Y", targets, sigma_mm=0.0, seed=1)
    ripple = 0.002 * np.sin(2 * np.pi * targets / 40.0)  # a 40 mm leadscrew period, 2 µm
    _, info = identify_axis(m, "Y", targets, test.deviations + ripple[:, None, None])
    assert info["max_mean_misfit_um"] > 0.5


@pytest.mark.slow
def test_two_u_intervals_cover_the_truth_at_the_expected_rate(setup):
    m, truth, targets = setup
    trials = 200
    inside = np.zeros(4)
    for k in range(trials):
        test = simulate_test(m, truth, "Y", targets, sigma_mm=0.001, seed=1000 + k)
        pset, _ = identify_axis(m, "Y", targets, test.deviations)
        inside += np.abs(pset.values - truth.values) <= 2 * pset.standard_uncertainty
    rate = inside / trials
    # binomial sd at p = 0.954 over 200 trials is 0.015: 3 sd either side
    assert np.all((rate > 0.954 - 0.045) & (rate < 0.954 + 0.045)), rate


def test_degrees_can_be_chosen_and_out_of_travel_targets_are_refused(setup):
    m, truth, targets = setup
    test = simulate_test(m, truth, "Y", targets, sigma_mm=0.0005, seed=3)
    pset, _ = identify_axis(m, "Y", targets, test.deviations, degrees=[1, 2, 3, 4, 5])
    assert pset.names[-2:] == ("E_YY5", "E_YYb")
    with pytest.raises(InputError, match="outside the travel"):
        identify_axis(m, "Y", targets + 100.0, test.deviations)
    with pytest.raises(InputError, match="not a linear axis"):
        identify_axis(m, "B", targets, test.deviations)


def test_two_laser_runs_combine_into_a_tighter_e_xx(setup):
    from mtmetrology.identification.combine import combine_parameter_sets

    m, truth, targets = setup
    sets = [
        identify_axis(m, "Y", targets, simulate_test(m, truth, "Y", targets, seed=s).deviations)[0]
        for s in (21, 22)
    ]
    c = combine_parameter_sets(*sets)
    assert c.names == sets[0].names
    assert np.all(c.standard_uncertainty < np.minimum(*(s.standard_uncertainty for s in sets)))
