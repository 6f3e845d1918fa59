"""Machine: presets, forward kinematics, analytic Jacobians, inverse kinematics."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mtmetrology.kinematics import Machine, MachineFileError, list_presets
from mtmetrology.kinematics.config import parse_machine_spec

PRESET_MODELS = [
    ("five-axis-wcbxfzyst", "13"),
    ("five-axis-wcbxfzyst", "84"),
    ("three-axis-xfyz", None),
    ("cmm-moving-bridge", None),
]


def random_state(m: Machine, n: int, rng: np.random.Generator):
    """Readings inside the travels, errors of 50 customary units (µm, µrad, µm/m ...)."""
    lo = np.array([m.axes[a].travel[0] for a in m.axis_names])
    hi = np.array([m.axes[a].travel[1] for a in m.axis_names])
    q = lo + (hi - lo) * rng.random((n, m.n_axes))
    theta = 50.0 * rng.standard_normal((n, m.n_params)) * m.parameter_scales
    senses = rng.choice([-1.0, 1.0], size=(n, m.n_axes))
    tool = m.tool + 20.0 * rng.standard_normal((n, 3))
    return q, theta, senses, tool


def rot_y(b):
    c, s = np.cos(b), np.sin(b)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(g):
    c, s = np.cos(g), np.sin(g)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def test_presets_are_listed_and_load():
    assert set(list_presets()) == {"five-axis-wcbxfzyst", "three-axis-xfyz", "cmm-moving-bridge"}
    assert Machine.load("five-axis-wcbxfzyst").n_params == 13
    assert Machine.load("five-axis-wcbxfzyst", "84").n_params == 84
    assert Machine.load("three-axis-xfyz").topology.string == "WXFYZT"
    assert Machine.load("cmm-moving-bridge").topology.string == "WFYXZT"


@pytest.mark.parametrize(
    ("readings", "published"),
    [
        ((-138.5650, 94.6560, 196.2320, -42.0, -293.0), (-178.6461, -178.6461, 53.1107)),
        ((-61.2880, 48.3440, 246.8170, -64.0, -124.0), (179.1009, 179.0881, 53.1067)),
    ],
)
def test_nominal_convention_reproduces_seed000_table_7_1(readings, published):
    """Digest 000 §3.2.2 (test T11): q = R_z(C) R_y(B) p within 0.1 mm of the published
    compensated coordinates; the difference (25-64 µm) is the geometric-error correction."""
    m = Machine.load("five-axis-wcbxfzyst")
    q = m.readings_from_customary(dict(zip("XYZBC", readings, strict=True)))
    p = m.forward(q)
    assert np.max(np.abs(p - published)) < 0.1
    assert np.max(np.abs(p - published)) > 0.01  # the correction is not zero


@settings(max_examples=50, deadline=None)
@given(
    xyz=st.lists(st.floats(-250, 250), min_size=3, max_size=3),
    b=st.floats(-np.pi / 2, np.pi / 2),
    c=st.floats(-2 * np.pi, 2 * np.pi),
)
def test_zero_errors_give_the_nominal_kinematics(xyz, b, c):
    m = Machine.load("five-axis-wcbxfzyst")
    q = np.array([*xyz, b, c, 0.0])
    expected = rot_z(c) @ rot_y(b) @ np.array(xyz)
    np.testing.assert_allclose(m.forward(q), expected, atol=1e-9)


@settings(max_examples=30, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    alpha=st.floats(-np.pi, np.pi),
)
def test_turning_the_table_turns_the_workpiece_frame(seed, alpha):
    """Turning the C table (sign −1) by α turns the stylus centre, seen from the workpiece,
    by R_z(α), whatever the location errors and scale gains: C carries only the workpiece."""
    m = Machine.load("five-axis-wcbxfzyst")
    rng = np.random.default_rng(seed)
    q, theta, _, _ = random_state(m, 5, rng)
    q2 = q.copy()
    q2[:, 4] += alpha
    np.testing.assert_allclose(
        m.forward(q2, theta), m.forward(q, theta) @ rot_z(alpha).T, atol=1e-9
    )


@settings(max_examples=30, deadline=None)
@given(
    offset=st.lists(st.floats(-500, 500), min_size=3, max_size=3), seed=st.integers(0, 2**32 - 1)
)
def test_moving_the_workpiece_origin_translates_positions(offset, seed):
    spec = Machine.load("three-axis-xfyz").spec
    moved = spec.model_copy(update={"workpiece_offset_mm": tuple(offset)})
    m0 = Machine.from_spec(spec)
    m1 = Machine.from_spec(moved)
    q, theta, _, _ = random_state(m0, 4, np.random.default_rng(seed))
    np.testing.assert_allclose(m1.forward(q, theta), m0.forward(q, theta) - offset, atol=1e-9)


@pytest.mark.parametrize(("name", "model"), PRESET_MODELS)
def test_parameter_jacobian_matches_central_differences(name, model):
    """The model is affine in each single parameter (every error transform is linear in its
    parameters), so central differences with a large step are exact up to rounding."""
    m = Machine.load(name, model)
    q, theta, senses, tool = random_state(m, 6, np.random.default_rng(7))
    jac = m.jacobian(q, theta, senses=senses, tool=tool)
    for j in range(m.n_params):
        h = 10.0 * m.parameter_scales[j]
        tp, tm = theta.copy(), theta.copy()
        tp[:, j] += h
        tm[:, j] -= h
        fd = (
            m.forward(q, tp, senses=senses, tool=tool) - m.forward(q, tm, senses=senses, tool=tool)
        ) / (2 * h)
        scale = max(np.abs(jac[..., j]).max(), 1e-300)
        assert np.abs(fd - jac[..., j]).max() / scale < 1e-6, m.parameter_names[j]


@pytest.mark.parametrize(("name", "model"), PRESET_MODELS)
def test_axis_and_tool_jacobians_match_central_differences(name, model):
    m = Machine.load(name, model)
    q, theta, senses, tool = random_state(m, 6, np.random.default_rng(11))
    ev = m.evaluate(q, theta, senses=senses, tool=tool, d_axes=True, d_tool=True)
    h = 1e-5
    for k in range(m.n_axes):
        qp, qm = q.copy(), q.copy()
        qp[:, k] += h
        qm[:, k] -= h
        fd = (
            m.forward(qp, theta, senses=senses, tool=tool)
            - m.forward(qm, theta, senses=senses, tool=tool)
        ) / (2 * h)
        col = ev.d_axes[..., k]
        assert np.abs(fd - col).max() / max(np.abs(col).max(), 1.0) < 1e-6, m.axis_names[k]
    for k in range(3):
        tp, tm = tool.copy(), tool.copy()
        tp[:, k] += 1.0
        tm[:, k] -= 1.0
        fd = (
            m.forward(q, theta, senses=senses, tool=tp)
            - m.forward(q, theta, senses=senses, tool=tm)
        ) / 2.0
        np.testing.assert_allclose(fd, ev.d_tool[..., k], atol=1e-9)


def test_broadcasting_trials_against_points():
    m = Machine.load("five-axis-wcbxfzyst")
    rng = np.random.default_rng(2)
    q, _, _, _ = random_state(m, 4, rng)  # 4 points
    theta = 30.0 * rng.standard_normal((7, 1, m.n_params)) * m.parameter_scales  # 7 trials
    p = m.forward(q, theta)
    assert p.shape == (7, 4, 3)
    np.testing.assert_allclose(p[3, 2], m.forward(q[2], theta[3, 0]))
    assert m.jacobian(q, theta).shape == (7, 4, 3, 13)


@pytest.mark.parametrize(("name", "model"), PRESET_MODELS)
def test_forward_of_inverse_is_identity(name, model):
    m = Machine.load(name, model)
    rng = np.random.default_rng(5)
    q, theta, senses, tool = random_state(m, 50, rng)
    target = m.forward(q, theta, senses=senses, tool=tool)
    start = q.copy()
    start[:, [m.axis_names.index(a) for a in m.linear_axes]] = 0.0
    back = m.inverse(target, start, theta, senses=senses, tool=tool)
    np.testing.assert_allclose(
        m.forward(back, theta, senses=senses, tool=tool), target, rtol=0, atol=1e-9
    )
    np.testing.assert_allclose(back, q, atol=1e-8)


def test_inverse_snaps_to_the_resolution_grid():
    m = Machine.load("five-axis-wcbxfzyst")
    q = m.readings_from_customary({"X": 10.00031, "Y": -5.0, "Z": 20.0, "B": 30, "C": 45})
    target = m.forward(q)
    snapped = m.inverse(target, q, snap=True)
    res = m.axes["X"].resolution
    assert np.allclose(snapped[:3] / res, np.round(snapped[:3] / res), atol=1e-6)
    assert abs(snapped[0] - 10.0005) < 1e-12  # 10.00031 -> nearest 0.5 µm step


def test_reversal_term_flips_with_the_sense_of_motion():
    m = Machine.load("five-axis-wcbxfzyst", "84")
    q = m.readings_from_customary({"X": 50, "Y": 20, "Z": 100, "B": 30, "C": 60})
    theta = np.zeros(m.n_params)
    theta[m.parameter_names.index("E_BBb")] = 10e-6  # 10 µrad
    up = m.forward(q, theta, senses=np.ones(6))
    down = m.forward(q, theta, senses=-np.ones(6))
    nominal = m.forward(q)
    np.testing.assert_allclose(up - nominal, -(down - nominal), atol=1e-12)
    assert np.linalg.norm(up - nominal) > 1e-4
    with pytest.raises(ValueError, match="sense of motion"):
        m.forward(q, theta)


def test_shape_errors_name_the_axes():
    m = Machine.load("five-axis-wcbxfzyst")
    with pytest.raises(ValueError, match=r"\(\.\.\., 6\) for axes XYZBCS"):
        m.forward(np.zeros(5))
    with pytest.raises(ValueError, match="parameters must have shape"):
        m.forward(np.zeros(6), np.zeros(3))
    with pytest.raises(ValueError, match="three linear axes"):
        Machine.from_topology("WCFZYT").inverse(np.zeros(3), np.zeros(4))


def spec(**over):
    base = {
        "name": "test",
        "topology": "WXFYZT",
        "axes": {"X": {"travel_mm": [0, 100]}},
        "error_models": {"m": {"parameters": ["E_XX1"]}},
    }
    base.update(over)
    return base


@pytest.mark.parametrize(
    ("data", "message"),
    [
        (spec(axes={"X": {"travel_deg": [0, 10]}}), r"axes\.X\.travel_deg: a linear axis"),
        (spec(axes={"X": {"travel_mm": [10, 0]}}), r"axes\.X\.travel_mm.*min < max"),
        (spec(axes={"Q": {}}), r"axes\.Q: axis not in topology"),
        (spec(axes={"X": {"direction": "+Q"}}), r"axes\.X\.direction"),
        (spec(topology="WXXFYZT"), "topology: .*repeated axis"),
        (spec(error_models={"m": {"parameters": ["E_QQ1"]}}), "not an ISO 230-1 error name"),
        (spec(error_models={"m": {"parameters": ["E_XB1"]}}), "axis B, not in topology"),
        (spec(error_models={"m": {"parameters": ["E_XX1", "E_XX1"]}}), "listed twice"),
        (
            spec(error_models={"m": {"basis": "legendre", "parameters": ["E_YY1"]}}),
            r"axes\.Y: the legendre basis .* travel_mm is required",
        ),
        (spec(unknown_field=1), "unknown_field"),
    ],
)
def test_bad_machine_files_name_the_field(data, message):
    with pytest.raises(MachineFileError, match=message):
        Machine.from_spec(parse_machine_spec(data, "m.yaml"), source="m.yaml")


def test_machine_file_round_trip(tmp_path):
    path = tmp_path / "machine.yaml"
    path.write_text(
        "kind: machine\nname: mine\ntopology: WXFYZT\n"
        "axes:\n  X: {travel_mm: [0, 500]}\n"
        "error_models:\n  m: {motions: {E_XX: [1, 2]}, parameters: [E_C0Y]}\n",
        encoding="utf-8",
    )
    m = Machine.load(path)
    assert m.parameter_names == ("E_XX1", "E_XX2", "E_C0Y")
    assert m.parameter_units == ("µm/m", "µm/m^2", "µrad")
    with pytest.raises(MachineFileError, match="neither a machine file nor a preset"):
        Machine.load(tmp_path / "missing.yaml")


@pytest.mark.parametrize(("name", "model"), PRESET_MODELS)
def test_chunked_evaluation_equals_one_block(name, model):
    """Large inputs are evaluated in cache-sized blocks; the blocks must not show."""
    m = Machine.load(name, model)
    rng = np.random.default_rng(9)
    q, theta, senses, tool = random_state(m, 40, rng)
    whole = m.evaluate(
        q[:, None],
        theta[:5],
        senses=senses[:, None],
        tool=tool[:5],
        d_params=True,
        d_axes=True,
        d_tool=True,
    )
    m.chain.chunk_size = 7
    parts = m.evaluate(
        q[:, None],
        theta[:5],
        senses=senses[:, None],
        tool=tool[:5],
        d_params=True,
        d_axes=True,
        d_tool=True,
    )
    assert parts.position.shape == (40, 5, 3)
    for a, b in [
        (whole.position, parts.position),
        (whole.d_params, parts.d_params),
        (whole.d_axes, parts.d_axes),
        (whole.d_tool, parts.d_tool),
    ]:
        np.testing.assert_allclose(a, b, rtol=1e-14, atol=1e-15)


@pytest.mark.parametrize("chunk", [8, 3])
def test_per_trial_readings_and_parameters_equal_a_loop_over_trials(chunk):
    """The Monte Carlo layout of a measurement task: readings (M, n, k) and parameters
    (M, 1, P) both per trial; blocks of whole trials (n ≤ chunk) and flat blocks (n > chunk)."""
    m = Machine.load("five-axis-wcbxfzyst")
    rng = np.random.default_rng(4)
    q, theta, _, _ = random_state(m, 6 * 4, rng)
    q, theta = q.reshape(6, 4, m.n_axes), theta[:6, None, :]
    m.chain.chunk_size = chunk
    batched = m.evaluate(q, theta, d_params=True)
    for t in range(6):
        one = m.evaluate(q[t], theta[t, 0], d_params=True)
        np.testing.assert_allclose(batched.position[t], one.position, rtol=1e-14, atol=1e-12)
        np.testing.assert_allclose(batched.d_params[t], one.d_params, rtol=1e-14, atol=1e-15)


@settings(max_examples=40, deadline=None)
@given(xyz=st.lists(st.floats(-1000, 1000), min_size=3, max_size=3), seed=st.integers(0, 2**32 - 1))
@pytest.mark.parametrize("name", ["three-axis-xfyz", "cmm-moving-bridge"])
def test_zero_errors_of_three_axis_machines_add_readings_and_tool(name, xyz, seed):
    """With no errors a Cartesian machine reports its readings: p = (x, y, z) + t,
    whichever branch carries each axis (sign −1 on the workpiece side)."""
    m = Machine.load(name)
    tool = np.random.default_rng(seed).normal(size=3) * 100
    np.testing.assert_allclose(m.forward(np.array(xyz), tool=tool), np.array(xyz) + tool, atol=1e-9)
