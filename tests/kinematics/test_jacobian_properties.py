"""Property tests of the public kinematic API: Jacobians against central differences over
random poses, parameters, senses and tools drawn by hypothesis, for every preset.

The position is affine in each single parameter (every error transform is linear in its
parameters), so a central difference in a parameter is exact up to rounding whatever the
step; in an axis reading it has a truncation error O(h²·|p'''|), below 1e-8 relative for
h = 1e-4 mm or rad at the scale of these machines.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mtmetrology.kinematics import Machine

PRESETS = [
    ("five-axis-wcbxfzyst", "13"),
    ("five-axis-wcbxfzyst", "84"),
    ("three-axis-xfyz", None),
    ("cmm-moving-bridge", None),
]
MACHINES = {key: Machine.load(*key) for key in PRESETS}


def state(m: Machine, seed: int, n: int = 3, size: float = 50.0):
    rng = np.random.default_rng(seed)
    lo = np.array([m.axes[a].travel[0] for a in m.axis_names])
    hi = np.array([m.axes[a].travel[1] for a in m.axis_names])
    q = lo + (hi - lo) * rng.random((n, m.n_axes))
    theta = size * rng.standard_normal(m.n_params) * m.parameter_scales
    senses = rng.choice([-1.0, 1.0], size=(n, m.n_axes))
    tool = m.tool + 30.0 * rng.standard_normal(3)
    return q, theta, senses, tool


SEEDS = st.integers(min_value=0, max_value=2**32 - 1)


def every_preset(test):
    """Run a property test on every preset and model, over 8 random states each."""
    test = given(seed=SEEDS)(test)
    test = settings(max_examples=8, deadline=None)(test)
    return pytest.mark.parametrize("key", PRESETS, ids=[f"{p}-{m}" for p, m in PRESETS])(test)


@every_preset
def test_parameter_jacobian_is_the_derivative(key, seed):
    m = MACHINES[key]
    q, theta, senses, tool = state(m, seed)
    jac = m.jacobian(q, theta, senses=senses, tool=tool)
    assert jac.shape == (3, 3, m.n_params)
    steps = 100.0 * m.parameter_scales  # 100 µm, µrad, µm/m ...: exact for an affine map
    eye = np.eye(m.n_params)
    # one trial per parameter j (theta ± step_j e_j), broadcast against the 3 points
    plus = m.forward(q, (theta + steps[:, None] * eye)[:, None, :], senses=senses, tool=tool)
    minus = m.forward(q, (theta - steps[:, None] * eye)[:, None, :], senses=senses, tool=tool)
    fd = np.moveaxis((plus - minus) / (2.0 * steps[:, None, None]), 0, -1)
    scale = np.abs(jac).max()
    assert np.abs(fd - jac).max() <= 1e-7 * scale


@every_preset
def test_axis_jacobian_is_the_derivative(key, seed):
    m = MACHINES[key]
    q, theta, senses, tool = state(m, seed)
    jac = m.axis_jacobian(q, theta, senses=senses, tool=tool)
    assert jac.shape == (3, 3, m.n_axes)
    h = 1e-4
    for k in range(m.n_axes):
        dq = np.zeros(m.n_axes)
        dq[k] = h
        fd = (
            m.forward(q + dq, theta, senses=senses, tool=tool)
            - m.forward(q - dq, theta, senses=senses, tool=tool)
        ) / (2 * h)
        assert np.abs(fd - jac[..., k]).max() <= 1e-7 * max(np.abs(jac[..., k]).max(), 1.0)


@every_preset
def test_evaluate_returns_what_forward_and_the_jacobians_return(key, seed):
    m = MACHINES[key]
    q, theta, senses, tool = state(m, seed)
    ev = m.evaluate(q, theta, senses=senses, tool=tool, d_params=True, d_axes=True, d_tool=True)
    np.testing.assert_array_equal(ev.position, m.forward(q, theta, senses=senses, tool=tool))
    np.testing.assert_allclose(
        ev.d_params, m.jacobian(q, theta, senses=senses, tool=tool), rtol=1e-13, atol=1e-15
    )
    # the position is affine in the tool vector: p(t + d) = p(t) + (∂p/∂t)·d exactly
    d = np.array([3.0, -7.0, 11.0])
    moved = m.forward(q, theta, senses=senses, tool=tool + d)
    np.testing.assert_allclose(moved, ev.position + ev.d_tool @ d, atol=1e-9)


@every_preset
def test_inverse_undoes_forward(key, seed):
    """inverse(forward(q)) returns the linear readings that were used, with the same
    errors, senses and tool; rotary readings are held."""
    m = MACHINES[key]
    q, theta, senses, tool = state(m, seed)
    p = m.forward(q, theta, senses=senses, tool=tool)
    start = q.copy()
    linear = [k for k, a in enumerate(m.axis_names) if a in "XYZ"]
    start[:, linear] = 0.0
    back = m.inverse(p, start, theta, senses=senses, tool=tool)
    np.testing.assert_allclose(back, q, atol=1e-9)
