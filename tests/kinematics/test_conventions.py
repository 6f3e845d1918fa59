"""Sign conventions and reference points of every error parameter, pinned.

For every preset and every parameter of its error model, one parameter is set to one
customary unit (1 µm, 1 µrad, 1 µm/m ...) and the engine's tool-to-workpiece deviation is
compared at several poses with an independent 4×4 homogeneous chain written here from
ISO 230-1: small-angle matrices by hand, the preset geometry typed in, table-side error
motions entered as the inverse displacement of the table (ISO 230-1 / ISO 841: an error
motion is the deviation of the tool relative to the workpiece whichever component moves).
Flipping the sign of the translational or rotational part of any error transform in the
engine fails these tests.  Closed-form values (hand-derived) pin the headline cases.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.polynomial import chebyshev, legendre

from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.conventions import describe_parameter, machine_description
from mtmetrology.kinematics.parameters import parse_parameter

# ---------------------------------------------------------------------------------------
# The independent chain


def trans(v) -> np.ndarray:
    t = np.eye(4)
    t[:3, 3] = v
    return t


def rot(axis: str, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    r = {
        "X": [[1, 0, 0], [0, c, -s], [0, s, c]],
        "Y": [[c, 0, s], [0, 1, 0], [-s, 0, c]],
        "Z": [[c, -s, 0], [s, c, 0], [0, 0, 1]],
    }[axis]
    t = np.eye(4)
    t[:3, :3] = r
    return t


def small(dx=0.0, dy=0.0, dz=0.0, ea=0.0, eb=0.0, ec=0.0) -> np.ndarray:
    """ISO 230-1 small-displacement matrix: translations δ, rotations ε (right-hand)."""
    return np.array(
        [
            [1.0, -ec, eb, dx],
            [ec, 1.0, -ea, dy],
            [-eb, ea, 1.0, dz],
            [0.0, 0.0, 0.0, 1.0],
        ]
    )


ROTARY_DIRECTION = {"A": "X", "B": "Y", "C": "Z", "S": "Z"}

# Preset geometry typed in from the YAML files: (branch order from F outwards, with
# direction letter, sign, offset mm, travel for normalised bases), tool vector, basis.
PRESETS = {
    "five-axis-wcbxfzyst": {
        "workpiece": [
            ("X", "X", -1, (0, 0, 0)),
            ("B", "Y", -1, (0, 0, 0)),
            ("C", "Z", -1, (0, 0, 0)),
        ],
        "tool": [("Z", "Z", 1, (0, 0, 150)), ("Y", "Y", 1, (0, 0, 0)), ("S", "Z", 1, (0, 0, 0))],
        "tool_vector": (0, 0, -150),
        "basis": "monomial",
        "travel": {},
        "order": "XYZBCS",
        "poses": [
            {"X": 200, "Y": 100, "Z": 50, "B": 0, "C": 0, "S": 0},
            {"X": -150, "Y": 60, "Z": 180, "B": 30, "C": 120, "S": 90},
            {"X": 90, "Y": -120, "Z": -60, "B": -75, "C": -200, "S": 270},
            {"X": 10, "Y": 170, "Z": 10, "B": 60, "C": 45, "S": 180},
        ],
    },
    "three-axis-xfyz": {
        "workpiece": [("X", "X", -1, (0, 0, 0))],
        "tool": [("Y", "Y", 1, (0, 0, 0)), ("Z", "Z", 1, (0, 0, 0))],
        "tool_vector": (0, 0, -100),
        "basis": "legendre",
        "travel": {"X": (800, 1200), "Y": (100, 500), "Z": (200, 400)},
        "order": "XYZ",
        "poses": [
            {"X": 1000, "Y": 300, "Z": 300},
            {"X": 820, "Y": 480, "Z": 390},
            {"X": 1150, "Y": 140, "Z": 230},
        ],
    },
    "cmm-moving-bridge": {
        "workpiece": [],
        "tool": [("Y", "Y", 1, (0, 0, 0)), ("X", "X", 1, (0, 0, 0)), ("Z", "Z", 1, (0, 0, 0))],
        "tool_vector": (20, -30, -150),
        "basis": "chebyshev",
        "travel": {"X": (0, 1200), "Y": (0, 1000), "Z": (0, 700)},
        "order": "XYZ",
        "poses": [
            {"X": 600, "Y": 500, "Z": 350},
            {"X": 100, "Y": 900, "Z": 650},
            {"X": 1150, "Y": 80, "Z": 40},
        ],
    },
}

MICRO = 1e-3  # µm in mm; µrad in rad is 1e-6


def basis_value(preset: dict, axis: str, degree: int, position: float) -> float:
    """φ_d of the preset's basis; position in customary units (mm or degrees)."""
    if preset["basis"] == "monomial":
        q = position / 1000.0 if axis in "XYZ" else np.deg2rad(position)  # m or rad
        return q**degree
    lo, hi = preset["travel"][axis]
    u = (position - 0.5 * (lo + hi)) / (0.5 * (hi - lo))
    coefficients = np.zeros(degree + 1)
    coefficients[degree] = 1.0
    if preset["basis"] == "legendre":
        return float(legendre.legval(u, coefficients))
    return float(chebyshev.chebval(u, coefficients))


def error_matrix(name: str, value: float, preset: dict, pose: dict, sense: float) -> np.ndarray:
    """The small displacement of one parameter (customary value) at a pose."""
    p = parse_parameter(name)
    if p.kind == "location":
        f = 1.0
    elif p.kind == "reversal":
        f = sense
    else:
        f = basis_value(preset, p.axis, p.degree, pose[p.axis])
    amount = value * f * (MICRO if p.component < 3 else 1e-6)
    args = [0.0] * 6
    args[p.component] = amount
    return small(*args)


def independent_position(preset: dict, params: dict, pose: dict, sense: float = 1.0):
    """Stylus centre in the workpiece frame by the 4×4 chain (params: name -> customary)."""

    def branch_matrix(axes, side):
        t = np.eye(4)
        for axis, letter, sign, offset in axes:
            t = t @ trans(offset)
            for name, value in params.items():
                p = parse_parameter(name)
                if p.axis == axis and p.kind == "location":
                    t = t @ error_matrix(name, value, preset, pose, sense)
            if axis in "XYZ":
                u = np.eye(3)["XYZ".index(letter)]
                t = t @ trans(sign * pose[axis] * u)
            else:
                t = t @ rot(letter, sign * np.deg2rad(pose[axis]))
            for name, value in params.items():
                p = parse_parameter(name)
                if p.axis == axis and p.kind != "location":
                    e = error_matrix(name, value, preset, pose, sense)
                    # the tool deviates by +G relative to the workpiece: a table moves by -G
                    t = t @ (np.linalg.inv(e) if side == "workpiece" else e)
        return t

    table = branch_matrix(preset["workpiece"], "workpiece")
    tool = branch_matrix(preset["tool"], "tool")
    stylus = tool @ np.r_[preset["tool_vector"], 1.0]
    return (np.linalg.inv(table) @ stylus)[:3]


def engine_position(machine: Machine, preset: dict, params: dict, pose: dict, sense=1.0):
    q = machine.readings_from_customary({a: pose.get(a, 0.0) for a in machine.axis_names})
    theta = np.zeros(machine.n_params)
    for name, value in params.items():
        i = machine.parameter_names.index(name)
        theta[i] = value * machine.parameter_scales[i]
    senses = np.full(machine.n_axes, sense)
    tool = np.asarray(preset["tool_vector"], dtype=float)
    return machine.forward(q, theta, senses=senses, tool=tool)


MODELS = [
    ("five-axis-wcbxfzyst", "13"),
    ("five-axis-wcbxfzyst", "84"),
    ("three-axis-xfyz", None),
    ("cmm-moving-bridge", None),
]


@pytest.mark.parametrize(("preset_name", "model"), MODELS)
def test_independent_chain_reproduces_the_nominal_kinematics(preset_name, model):
    m = Machine.load(preset_name, model)
    preset = PRESETS[preset_name]
    for pose in preset["poses"]:
        np.testing.assert_allclose(
            engine_position(m, preset, {}, pose), independent_position(preset, {}, pose), atol=1e-9
        )


@pytest.mark.parametrize(("preset_name", "model"), MODELS)
@pytest.mark.parametrize("sense", [1.0, -1.0])
def test_every_parameter_deviates_the_tool_as_iso_230_1_says(preset_name, model, sense):
    """One customary unit of each parameter, at every pose: engine deviation = 4×4 chain
    deviation (second-order differences of 1-µrad errors are below 1e-9 mm)."""
    m = Machine.load(preset_name, model)
    preset = PRESETS[preset_name]
    for pose in preset["poses"]:
        nominal = independent_position(preset, {}, pose)
        for name in m.parameter_names:
            expected = independent_position(preset, {name: 1.0}, pose, sense) - nominal
            got = engine_position(m, preset, {name: 1.0}, pose, sense) - nominal
            np.testing.assert_allclose(got, expected, atol=2e-9, err_msg=f"{name} at {pose}")


# ---------------------------------------------------------------------------------------
# Closed-form values, derived by hand


def five_axis(params: dict, **pose) -> np.ndarray:
    m = Machine.load("five-axis-wcbxfzyst").with_parameters(list(params))
    full = {"X": 0.0, "Y": 0.0, "Z": 0.0, "B": 0.0, "C": 0.0, "S": 0.0, **pose}
    return engine_position(m, PRESETS["five-axis-wcbxfzyst"], params, full)


def test_positioning_slope_has_one_sign_on_table_and_tool_axes():
    """E_XX1 = E_YY1 = +100 µm/m: X = 200 mm reads x = 200.02 mm (X moves the table), Y = 100
    mm reads y = 100.01 mm (Y moves the spindle): the same ISO 230-2 slope, the same sign."""
    np.testing.assert_allclose(five_axis({"E_XX1": 100.0}, X=200.0), [200.02, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(five_axis({"E_YY1": 100.0}, Y=100.0), [0.0, 100.01, 0.0], atol=1e-12)
    np.testing.assert_allclose(five_axis({"E_ZZ1": 100.0}, Z=100.0), [0.0, 0.0, 100.01], atol=1e-12)


def test_table_location_error_shifts_the_axis_line_in_the_machine_frame():
    """E_X0C = +10 µm moves the C axis line (and the table) +X: at C = 0 the tool reads
    -10 µm in x relative to the workpiece; at C = 180° the table turns about the shifted
    line, the workpiece origin moves to x = +20 µm and the tool reads x = +10 µm."""
    np.testing.assert_allclose(five_axis({"E_X0C": 10.0}), [-0.010, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(five_axis({"E_X0C": 10.0}, C=180.0), [0.010, 0.0, 0.0], atol=1e-12)


def test_spindle_tilt_is_referred_to_the_gauge_line_150_mm_above_the_stylus():
    """E_B0Z = +10 µrad tilts Z about +Y at its reference point (0, 0, 150) mm: at reading Z
    the gauge line moves x = +ε·Z and the stylus 150 mm below it x = -ε·150 mm, so the tip
    reads x = ε·(Z − 150 mm); E_X0S and E_Y0S are referred to the same gauge line."""
    eps = 10e-6
    for z in (0.0, 150.0, 200.0):
        got = five_axis({"E_B0Z": 10.0}, Z=z)
        assert got[0] == pytest.approx(eps * (z - 150.0), abs=1e-12)
    assert describe_parameter(Machine.load("five-axis-wcbxfzyst"), "E_X0S").reference_point_mm == (
        0.0,
        0.0,
        150.0,
    )


def test_rotary_table_error_motion_turns_the_tool_relative_to_the_workpiece():
    """E_CC1 = +1000 µrad/rad at C = 90°: the tool turns by +ε = 1000e-6 × π/2 rad about +Z
    relative to the workpiece, about the C reference point (the origin).  With X = 100 mm
    the nominal tip is at p = R_z(C)·(X, Y, Z) = (0, 100, 0) mm (seed 000 convention), so it
    deviates by ε ẑ × p = (−100 ε, 0, 0) mm."""
    eps = 1000e-6 * np.pi / 2
    got = five_axis({"E_CC1": 1000.0}, X=100.0, C=90.0)
    np.testing.assert_allclose(got, [-eps * 100.0, 100.0, 0.0], atol=1e-9)


def test_reversal_term_follows_the_sense_of_motion():
    m = Machine.load("five-axis-wcbxfzyst", "84")
    preset = PRESETS["five-axis-wcbxfzyst"]
    pose = {"X": 100.0, "Y": 0.0, "Z": 0.0, "B": 0.0, "C": 0.0, "S": 0.0}
    plus = engine_position(m, preset, {"E_CCb": 20.0}, pose, 1.0)
    minus = engine_position(m, preset, {"E_CCb": 20.0}, pose, -1.0)
    # +20 µrad about +Z at lever (100, 0, 0) mm: +2 µm in y, the opposite for sense -1
    np.testing.assert_allclose(plus - minus, [0.0, 2 * 20e-6 * 100.0, 0.0], atol=1e-12)


def test_squareness_of_three_axis_y_to_x():
    """E_C0Y = +10 µrad turns the Y line about +Z: moving +Y also moves the tool -X by ε·y
    (the angle between +X and +Y exceeds 90° by ε)."""
    m = Machine.load("three-axis-xfyz")
    preset = PRESETS["three-axis-xfyz"]
    a = engine_position(m, preset, {"E_C0Y": 10.0}, {"X": 1000.0, "Y": 400.0, "Z": 300.0})
    b = engine_position(m, preset, {}, {"X": 1000.0, "Y": 400.0, "Z": 300.0})
    np.testing.assert_allclose(a - b, [-10e-6 * 400.0, 0.0, 0.0], atol=1e-12)


def test_cmm_squareness_and_roll_with_stylus_offset():
    """CMM: E_C0X = +10 µrad turns the X line (on the bridge Y) about +Z: moving +X also
    moves +Y by ε·x.  E_AX1 (Chebyshev) turns the tool about +X by ε·T_1(u_x) about the X
    reference point: the stylus offset (20, -30, -150) mm moves by ε × r."""
    m = Machine.load("cmm-moving-bridge")
    preset = PRESETS["cmm-moving-bridge"]
    pose = {"X": 900.0, "Y": 500.0, "Z": 350.0}
    base = engine_position(m, preset, {}, pose)
    d = engine_position(m, preset, {"E_C0X": 10.0}, pose) - base
    # the X line turns with what it carries (Z, the stylus) about the X reference point
    # (the origin): the stylus at r = (x, 0, z) + offset moves by ε ẑ × r
    eps = 10e-6
    r = np.array([900.0, 0.0, 350.0]) + np.array([20.0, -30.0, -150.0])
    np.testing.assert_allclose(d, np.cross([0.0, 0.0, eps], r), atol=1e-12)
    u = (900.0 - 600.0) / 600.0
    d = engine_position(m, preset, {"E_AX1": 10.0}, pose) - base
    r = np.array([0.0, 0.0, 350.0]) + np.array([20.0, -30.0, -150.0])  # from the X frame origin
    np.testing.assert_allclose(d, np.cross([eps * u, 0.0, 0.0], r), atol=1e-12)


def test_machine_description_lists_every_parameter_with_its_convention():
    m = Machine.load("five-axis-wcbxfzyst", "84")
    doc = machine_description(m)
    assert [p["name"] for p in doc["parameters"]] == list(m.parameter_names)
    assert doc["stylus_at_zero_mm"] == [0.0, 0.0, 0.0]
    byname = {p["name"]: p for p in doc["parameters"]}
    assert byname["E_XX1"]["side"] == "workpiece" and byname["E_YY1"]["side"] == "tool"
    assert byname["E_XX1"]["reference_point_mm"] == [0.0, 0.0, 0.0]
    assert byname["E_YY1"]["reference_point_mm"] == [0.0, 0.0, 150.0]
    travel = {a["axis"]: a["travel"] for a in doc["axes"]}
    assert travel["B"] == pytest.approx([-90.0, 90.0]) and travel["X"] == [-220.0, 230.0]
