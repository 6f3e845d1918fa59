"""The compiled and the numpy backends of the kinematic chain compute the same model.

The compiled backend records the chain once as a program over trials
(:mod:`mtmetrology.kinematics._program`) and runs it in a numba kernel; the numpy backend
evaluates the sparse chain in blocks.  Both must agree to rounding (1e-12 relative to the
size of the positions) on every preset and model, every broadcasting layout and with
reversal terms; the numpy backend's blocks of whole trials must not show either.
"""

import numpy as np
import pytest

from mtmetrology.kinematics import Machine
from mtmetrology.kinematics import chain as kinematic_chain

pytest.importorskip("numba")

PRESET_MODELS = [
    ("five-axis-wcbxfzyst", "13"),
    ("five-axis-wcbxfzyst", "84"),
    ("three-axis-xfyz", None),
    ("cmm-moving-bridge", None),
]


def state(m: Machine, n_poses: int, n_trials: int, seed: int):
    rng = np.random.default_rng(seed)
    lo = np.array([m.axes[a].travel[0] for a in m.axis_names])
    hi = np.array([m.axes[a].travel[1] for a in m.axis_names])
    q = lo + (hi - lo) * rng.random((n_poses, m.n_axes))
    theta = 50.0 * rng.standard_normal((n_trials, 1, m.n_params)) * m.parameter_scales
    senses = rng.choice([-1.0, 1.0], size=(n_poses, m.n_axes))
    tool = m.tool + 20.0 * rng.standard_normal((n_poses, 3))
    return q, theta, senses, tool


def both(m: Machine, monkeypatch, *args, expect_kernel: bool = True, **kwargs):
    """evaluate() on the compiled backend (forced for any size) and on the numpy one;
    checks that the kernel ran (or not) on the first."""
    kernel = kinematic_chain._compiled_kernel()
    calls = []
    run = kernel.run
    monkeypatch.setattr(kernel, "run", lambda *a: calls.append(1) or run(*a))
    monkeypatch.setattr(m.chain, "compiled_min_pairs", 0)
    monkeypatch.setattr(m.chain, "compiled_min_trials", 1)
    monkeypatch.setattr(kinematic_chain, "BACKEND", "numba")
    compiled = m.evaluate(*args, **kwargs)
    assert len(calls) == int(expect_kernel)
    monkeypatch.setattr(kinematic_chain, "BACKEND", "numpy")
    reference = m.evaluate(*args, **kwargs)
    assert len(calls) == int(expect_kernel)
    return compiled, reference


def assert_agree(compiled, reference, scale):
    np.testing.assert_allclose(compiled.position, reference.position, rtol=0, atol=1e-12 * scale)
    if reference.d_params is not None:
        np.testing.assert_allclose(compiled.d_params, reference.d_params, rtol=0, atol=1e-12)


@pytest.mark.parametrize(("name", "model"), PRESET_MODELS)
def test_backends_agree_on_every_preset_and_model(name, model, monkeypatch):
    m = Machine.load(name, model)
    q, theta, senses, tool = state(m, 23, 37, seed=3)
    compiled, reference = both(m, monkeypatch, q, theta, senses=senses, tool=tool, d_params=True)
    assert compiled.position.shape == (37, 23, 3)
    assert compiled.d_params.shape == (37, 23, 3, m.n_params)
    assert_agree(compiled, reference, np.abs(reference.position).max())
    compiled, reference = both(m, monkeypatch, q, theta, senses=senses, tool=tool)
    assert_agree(compiled, reference, np.abs(reference.position).max())


@pytest.mark.parametrize(("name", "model"), [PRESET_MODELS[0], PRESET_MODELS[3]])
def test_generated_kernels_agree(name, model, monkeypatch):
    """Large position-only calls run a kernel generated for the program (compiled once
    per machine, about a second: two presets here, all instruction kinds)."""
    m = Machine.load(name, model)
    q, theta, senses, tool = state(m, 70, 300, seed=5)
    monkeypatch.setattr(m.chain, "generated_min_pairs", 0)
    kernel = kinematic_chain._compiled_kernel()
    generated = []
    build = kernel.kernel
    monkeypatch.setattr(kernel, "kernel", lambda *a: generated.append(1) or build(*a))
    compiled, reference = both(m, monkeypatch, q, theta, senses=senses, tool=tool)
    assert generated == [1]
    assert_agree(compiled, reference, np.abs(reference.position).max())


@pytest.mark.parametrize(
    ("q_shape", "theta_shape", "tool_shape"),
    [
        ((6,), (9, 13), (3,)),  # one pose, many trials
        ((5, 6), (9, 1, 13), (5, 3)),  # a tool per pose
        ((4, 5, 6), (2, 3, 1, 1, 13), (3,)),  # several trial and pose dimensions
        ((1, 5, 6), (7, 1, 13), (3,)),  # size-1 leading pose dimension
    ],
)
def test_backends_agree_on_every_broadcasting_layout(q_shape, theta_shape, tool_shape, monkeypatch):
    m = Machine.load("five-axis-wcbxfzyst")
    rng = np.random.default_rng(8)
    q = rng.uniform(-1.0, 1.0, q_shape) * 200.0
    theta = 50.0 * rng.standard_normal(theta_shape) * m.parameter_scales
    tool = m.tool + rng.standard_normal(tool_shape)
    compiled, reference = both(m, monkeypatch, q, theta, tool=tool, d_params=True)
    assert compiled.position.shape == reference.position.shape
    assert_agree(compiled, reference, np.abs(reference.position).max())


def test_mixed_layouts_and_other_jacobians_fall_back_to_numpy(monkeypatch):
    """Parameters varying over the pose dimensions, or a readings/tool Jacobian, take the
    numpy path: still the same numbers."""
    m = Machine.load("five-axis-wcbxfzyst")
    q, theta, _, _ = state(m, 6, 4, seed=1)
    per_pair = np.broadcast_to(theta, (4, 6, 13)) * np.linspace(0.5, 1.5, 6)[:, None]
    for layout, kwargs in ((per_pair, {"d_params": True}), (theta, {"d_axes": True})):
        compiled, reference = both(m, monkeypatch, q, layout, expect_kernel=False, **kwargs)
        np.testing.assert_array_equal(compiled.position, reference.position)


def test_numpy_blocks_of_whole_trials_do_not_show(monkeypatch):
    """Large separable calls run in blocks of whole trials: same as one block."""
    m = Machine.load("five-axis-wcbxfzyst", "84")
    q, theta, senses, tool = state(m, 10, 33, seed=4)
    monkeypatch.setattr(kinematic_chain, "BACKEND", "numpy")
    whole = m.evaluate(q, theta, senses=senses, tool=tool, d_params=True)
    monkeypatch.setattr(m.chain, "chunk_size", 100)  # 10 trials of 10 poses per block
    parts = m.evaluate(q, theta, senses=senses, tool=tool, d_params=True)
    np.testing.assert_array_equal(parts.position, whole.position)
    np.testing.assert_array_equal(parts.d_params, whole.d_params)
