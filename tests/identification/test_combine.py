"""Independent parameter sets combined by generalised least squares: the closed-form
weighted mean for shared names, each set's own estimate for the others."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.identification.combine import combine_parameter_sets
from mtmetrology.kinematics.parameter_set import ParameterSet


def pset(names, values, u, machine="m"):
    v = np.asarray(values, float)
    return ParameterSet(tuple(names), v, ("µm",) * v.size, np.diag(np.square(u)), machine=machine)


def test_shared_names_are_the_inverse_variance_mean_and_others_are_kept():
    laser = pset(["E_XX1", "E_XXb"], [0.010, 0.002], [0.0001, 0.00005])
    tracker = pset(["E_XX1", "E_YY1"], [0.0106, -0.004], [0.0002, 0.0003])
    c = combine_parameter_sets(laser, tracker)
    assert c.names == ("E_XX1", "E_XXb", "E_YY1")
    w1, w2 = 1 / 0.0001**2, 1 / 0.0002**2
    assert c.values[0] == pytest.approx((w1 * 0.010 + w2 * 0.0106) / (w1 + w2), rel=1e-12)
    assert c.standard_uncertainty[0] == pytest.approx((w1 + w2) ** -0.5, rel=1e-12)
    np.testing.assert_allclose(c.values[1:], [0.002, -0.004], rtol=1e-12)
    np.testing.assert_allclose(c.standard_uncertainty[1:], [0.00005, 0.0003], rtol=1e-12)


def test_a_correlated_set_passes_information_to_its_other_names():
    # set 1 says a and b are strongly correlated; set 2 pins a: b moves with it
    cov = np.array([[1.0, 0.9], [0.9, 1.0]]) * 1e-6
    s1 = ParameterSet(("E_XX1", "E_XX2"), np.zeros(2), ("µm", "µm"), cov, machine="m")
    s2 = pset(["E_XX1"], [0.001], [1e-5])
    c = combine_parameter_sets(s1, s2)
    assert c.values[1] == pytest.approx(0.9 * c.values[0], rel=1e-3)
    assert c.standard_uncertainty[1] < 1e-3


def test_sets_of_other_machines_or_without_covariance_are_refused():
    a = pset(["E_XX1"], [0.0], [1e-4])
    with pytest.raises(InputError, match="machine"):
        combine_parameter_sets(a, pset(["E_XX1"], [0.0], [1e-4], machine="other"))
    bare = ParameterSet(("E_XX1",), np.zeros(1), ("µm",), machine="m")
    with pytest.raises(InputError, match="no covariance"):
        combine_parameter_sets(a, bare)
    with pytest.raises(InputError, match="two"):
        combine_parameter_sets(a)
