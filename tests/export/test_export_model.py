"""The neutral compensation model: values, flag, reversal, covariance, grids."""

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.export.model import axis_grid, compensation_model
from mtmetrology.kinematics import Machine


def test_positioning_slope_tabulated_as_correction_is_minus_slope_times_position(make_set):
    """E_XX1 = +100 µm/m (monomial): E_XX(x) = 1e-4 x, so the correction is −1e-4 x."""
    m = Machine.load("five-axis-wcbxfzyst")
    cm = compensation_model(m, make_set(m, {"E_XX1": 100.0}), pitch=10)
    t = cm.table("E_XX")
    np.testing.assert_allclose(t.forward, -1e-4 * t.positions, atol=1e-15)
    assert t.side == "workpiece" and cm.table("E_ZZ").side == "tool"
    err = compensation_model(m, make_set(m, {"E_XX1": 100.0}), pitch=10, flag="error")
    np.testing.assert_array_equal(err.table("E_XX").forward, -t.forward)


def test_reversal_term_splits_forward_and_reverse_by_twice_its_value(make_set):
    """E_BBb = 5 µrad (u 1 µrad): the error is +5 µrad travelling +, −5 µrad travelling −;
    a forward and a reverse value covary by −u² (the same term with opposite signs)."""
    m = Machine.load("five-axis-wcbxfzyst", model="84")
    ps = make_set(m, {"E_BBb": 5.0}, u={"E_BBb": 1.0})
    cm = compensation_model(m, ps, pitch=10, flag="error")
    t = cm.table("E_BB")
    n = t.positions.size
    assert t.bidirectional and t.covariance.shape == (2 * n, 2 * n)
    np.testing.assert_allclose(t.forward, 5e-6)
    np.testing.assert_allclose(t.reverse, -5e-6)
    assert t.covariance[0, n] == pytest.approx(-1e-12)
    assert cm.table("E_XB").covariance.shape == (cm.table("E_XB").positions.size,) * 2


def test_covariance_of_tabulated_values_is_a_u_a_transpose(make_set):
    """Legendre E_XX1 on X ∈ [800, 1200]: φ1 = (x − 1000)/200, so u(v) = u(E_XX1)·|φ1|, and
    the values at x and 2000 − x are perfectly anti-correlated."""
    m = Machine.load("three-axis-xfyz")
    ps = make_set(m, {"E_XX1": 3.0}, u={"E_XX1": 0.5})
    t = compensation_model(m, ps, points=5).table("E_XX")
    phi = (t.positions - 1000.0) / 200.0
    np.testing.assert_allclose(t.u_forward, 0.5e-3 * np.abs(phi), atol=1e-15)
    corr = t.covariance[0, 4] / (t.u_forward[0] * t.u_forward[4])
    assert corr == pytest.approx(-1.0)


def test_axis_grid_is_equally_spaced_and_covers_the_travel():
    m = Machine.load("three-axis-xfyz")
    q = axis_grid(m, "X", pitch=30)
    assert q[0] == 800 and q[-1] >= 1200 and q[-2] < 1200
    np.testing.assert_allclose(np.diff(q), 30)
    np.testing.assert_allclose(axis_grid(m, "Z", points=3), [200, 300, 400])


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [({"pitch": 500}, "pitch"), ({"pitch": -1}, "pitch"), ({"points": 1}, "points")],
)
def test_bad_grids_are_refused_naming_the_field(kwargs, field):
    m = Machine.load("three-axis-xfyz")
    with pytest.raises(InputError, match=f"^{field}: "):
        axis_grid(m, "X", **kwargs)


def test_a_reference_on_an_axis_the_machine_does_not_have_is_refused(make_set):
    """Issue 32: ``--reference Q=0`` was silently ignored."""
    m = Machine.load("three-axis-xfyz")
    with pytest.raises(InputError) as info:
        compensation_model(m, make_set(m, {}), pitch=20, reference={"Q": 0.0})
    assert str(info.value) == "--reference: Q is not an axis of three-axis-xfyz (XYZ)"
