"""The kinematic chain's own properties: its analytic Jacobians are the derivatives of its
positions, the model is a product of factors each linear in its parameters, and it
reduces to the nominal rigid-body chain without errors.

Every preset and error model is checked: finite differences of ``position`` (central,
step chosen for rounding) against ``d_params``, ``d_axes`` and ``d_tool``; the tool
Jacobian is a rotation; and without errors the workpiece-to-tool distance of a pure
rotary motion is preserved.
"""

import numpy as np
import pytest

from mtmetrology.kinematics import Machine

PRESETS = [
    ("five-axis-wcbxfzyst", "13"),
    ("five-axis-wcbxfzyst", "84"),
    ("three-axis-xfyz", None),
    ("cmm-moving-bridge", None),
]


def pose(m: Machine, n: int, seed: int):
    rng = np.random.default_rng(seed)
    lo = np.array([m.axes[a].travel[0] for a in m.axis_names])
    hi = np.array([m.axes[a].travel[1] for a in m.axis_names])
    q = lo + (hi - lo) * rng.random((n, m.n_axes))
    theta = 20.0 * rng.standard_normal(m.n_params) * m.parameter_scales
    senses = rng.choice([-1.0, 1.0], size=(n, m.n_axes))
    tool = m.tool + 10.0 * rng.standard_normal(3)
    return q, theta, senses, tool


@pytest.mark.parametrize(("name", "model"), PRESETS)
def test_parameter_jacobian_is_the_derivative_of_the_position(name, model):
    """Each parameter enters one factor, linearly, so the position is affine in it: a
    difference quotient equals d_params exactly (to rounding) for any step; the step
    moves the tip by about 1 mm, which keeps rounding out of the quotient."""
    m = Machine.load(name, model)
    q, theta, senses, tool = pose(m, 7, seed=1)
    ev = m.evaluate(q, theta, senses=senses, tool=tool, d_params=True)
    h = 1.0 / np.abs(ev.d_params).max(axis=(0, 1))
    for j in range(m.n_params):
        step = np.zeros(m.n_params)
        step[j] = h[j]
        plus = m.forward(q, theta + step, senses=senses, tool=tool)
        minus = m.forward(q, theta - step, senses=senses, tool=tool)
        np.testing.assert_allclose(
            (plus - minus) / (2 * h[j]), ev.d_params[..., j], rtol=0, atol=1e-9 / h[j],
            err_msg=m.parameter_names[j],
        )  # fmt: skip


@pytest.mark.parametrize(("name", "model"), PRESETS)
def test_axis_and_tool_jacobians_are_the_derivatives_of_the_position(name, model):
    m = Machine.load(name, model)
    q, theta, senses, tool = pose(m, 5, seed=2)
    ev = m.evaluate(q, theta, senses=senses, tool=tool, d_axes=True, d_tool=True)
    for k in range(m.n_axes):
        h = 1e-3 if m.axes[m.axis_names[k]].linear else 1e-5
        step = np.zeros(m.n_axes)
        step[k] = h
        plus = m.forward(q + step, theta, senses=senses, tool=tool)
        minus = m.forward(q - step, theta, senses=senses, tool=tool)
        np.testing.assert_allclose(
            (plus - minus) / (2 * h), ev.d_axes[..., k], rtol=0, atol=1e-6,
            err_msg=m.axis_names[k],
        )  # fmt: skip
    # the position is affine in the tool vector: the difference quotient is exact
    for c in range(3):
        step = np.zeros(3)
        step[c] = 1.0
        moved = m.forward(q, theta, senses=senses, tool=tool + step)
        base = m.forward(q, theta, senses=senses, tool=tool)
        np.testing.assert_allclose(moved - base, ev.d_tool[..., c], rtol=0, atol=1e-9)
    # asked alone (once it failed when the model had error factors), the same matrix
    alone = m.evaluate(q, theta, senses=senses, tool=tool, d_tool=True).d_tool
    np.testing.assert_allclose(alone, ev.d_tool, rtol=0, atol=1e-15)


@pytest.mark.parametrize(("name", "model"), PRESETS)
def test_without_errors_the_tool_jacobian_is_a_rotation(name, model):
    """d_tool alone (no other Jacobian) once failed when the model had error factors."""
    m = Machine.load(name, model)
    q, _, _, tool = pose(m, 6, seed=3)
    r = m.evaluate(q, None, tool=tool, d_tool=True).d_tool
    np.testing.assert_allclose(r @ np.swapaxes(r, -1, -2), np.broadcast_to(np.eye(3), r.shape),
                               atol=1e-12)  # fmt: skip
    np.testing.assert_allclose(np.linalg.det(r), 1.0, atol=1e-12)


def test_a_rotary_axis_moves_the_tip_on_a_circle_about_its_line():
    """Without errors, turning C by any angle keeps the tip's distance from the C line
    and its height along it (the nominal motion is exact, not linearised)."""
    m = Machine.load("five-axis-wcbxfzyst")
    q, _, _, tool = pose(m, 1, seed=4)
    angles = np.linspace(0.0, 2 * np.pi, 12, endpoint=False)
    qs = np.repeat(q, angles.size, axis=0)
    qs[:, m.axis_names.index("C")] = angles
    p = m.forward(qs, None, tool=tool)
    # the C line is the workpiece frame's z axis through the table centre at B = reading
    centre = p.mean(axis=0)
    radius = np.linalg.norm((p - centre)[:, :2], axis=1)
    assert np.ptp(radius) < 1e-9 * max(1.0, radius.mean())
