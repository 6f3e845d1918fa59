"""The controls' interpolation rules, against hand-computed values."""

import numpy as np

from mtmetrology.export.control import ControlTable

X = np.array([0.0, 10.0, 20.0])
FWD = np.array([0.0, 1.0, 3.0])
REV = np.array([0.0, -1.0, -3.0])


def test_linear_interpolates_and_holds_the_end_values():
    t = ControlTable("E_XX", X, FWD, REV, "linear")
    np.testing.assert_allclose(t.correction([-5.0, 5.0, 15.0, 20.0, 30.0]), [0, 0.5, 2, 3, 3])


def test_staircase_holds_each_points_value_until_the_next():
    t = ControlTable("E_XX", X, FWD, REV, "staircase")
    np.testing.assert_allclose(t.correction([0.0, 9.99, 10.0, 19.0, 25.0]), [0, 0, 1, 1, 3])


def test_reverse_table_applies_to_negative_travel():
    t = ControlTable("E_XX", X, FWD, REV, "linear")
    np.testing.assert_allclose(t.correction([5.0, 5.0], senses=[1, -1]), [0.5, -0.5])


def test_modulo_table_repeats_with_its_period():
    t = ControlTable("E_CC", X, FWD, FWD, "linear", period=20.0)
    np.testing.assert_allclose(t.correction([25.0, -15.0]), [0.5, 0.5])
