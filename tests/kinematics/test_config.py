"""Machine-definition files: schema refusals that name the field, and what a valid file
builds (axis directions, signs, travels in internal units, bases, error models)."""

import re

import numpy as np
import pytest

from mtmetrology.errors import ConvergenceError, InputError
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.config import MachineFileError, load_machine_spec, parse_machine_spec
from mtmetrology.kinematics.conventions import describe_parameter, machine_description
from mtmetrology.units import from_internal

BASE = {"kind": "machine", "version": 1, "name": "m", "topology": "WXFYZT"}
PREFIX = "m.yaml: invalid machine definition: "


def _refusal(doc) -> str:
    with pytest.raises(MachineFileError) as err:
        parse_machine_spec(doc, "m.yaml")
    return str(err.value)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (
            {"axes": {"X": {"travel_mm": [5, 1]}}},
            "axes.X.travel_mm: travel must be [min, max] with min < max, got [5.0, 1.0]",
        ),
        (
            {"axes": {"X": {"travel_mm": [1, 1]}}},
            "axes.X.travel_mm: travel must be [min, max] with min < max, got [1.0, 1.0]",
        ),
        (
            {"axes": {"X": {"direction": "Q"}}},
            "axes.X.direction: direction 'Q': use +X, -Y, Z ... or a 3-vector",
        ),
        (
            {"axes": {"X": {"direction": "+XY"}}},
            "axes.X.direction: direction '+XY': use +X, -Y, Z ... or a 3-vector",
        ),
        (
            {"axes": {"X": {"direction": [0, 0, 0]}}},
            "axes.X.direction: direction vector must not be zero",
        ),
        (
            {"error_models": {"a": {"motions": {"E_QX": [1]}}}},
            "error_models.a.motions: motion function 'E_QX': expected an ISO 230-1 error "
            "motion such as 'E_XX' (error direction, moving axis)",
        ),
        (
            {"error_models": {"a": {"motions": {"X_XX": [1]}}}},
            "error_models.a.motions: motion function 'X_XX': expected an ISO 230-1 error "
            "motion such as 'E_XX' (error direction, moving axis)",
        ),
        (
            {"error_models": {"a": {"motions": {"E_XXX": [1]}}}},
            "error_models.a.motions: motion function 'E_XXX': expected an ISO 230-1 error "
            "motion such as 'E_XX' (error direction, moving axis)",
        ),
        (
            {"error_models": {"a": {"motions": {"E_XX": [1, -1]}}}},
            "error_models.a.motions: motion E_XX: degrees must be >= 0, got [1, -1]",
        ),
    ],
)
def test_schema_refusals_name_the_field(change, message):
    assert _refusal({**BASE, **change}) == PREFIX + message


@pytest.mark.parametrize(
    ("change", "field"),
    [
        ({"axes": {"X": {"resolution_mm": 0}}}, "axes.X.resolution_mm"),
        ({"axes": {"B": {"resolution_deg": -1}}}, "axes.B.resolution_deg"),
        ({"probe": {"tip_radius_mm": -1}}, "probe.tip_radius_mm"),
        ({"axes": {"X": {"sign": 2}}}, "axes.X.sign"),
        ({"axes": {"X": {"basis": "fourier"}}}, "axes.X.basis"),
        ({"tool_mm": [0, 0]}, "tool_mm.2"),
        ({"error_models": {"a": {"normalise": 1}}}, "error_models.a.normalise"),
    ],
)
def test_field_limits_are_enforced(change, field):
    assert _refusal({**BASE, **change}).startswith(PREFIX + field + ":")


def test_zero_travel_limits_and_motion_degree_zero_are_accepted():
    spec = parse_machine_spec(
        {
            **BASE,
            "axes": {"X": {"travel_mm": [0, 1], "direction": [0, 0, 2]}},
            "probe": {"tip_radius_mm": 0},
            "error_models": {"a": {"motions": {" E_XX ": [0, 3]}}},
        }
    )
    assert spec.axes["X"].travel_mm == (0.0, 1.0)
    assert spec.error_models["a"].motions == {" E_XX ": [0, 3]}


def test_a_non_mapping_is_refused():
    assert _refusal([1, 2]) == "m.yaml: a machine definition must be a mapping"


def test_defaults_of_a_minimal_definition():
    spec = parse_machine_spec({"name": "m", "topology": "WXFYZT"})
    assert (spec.kind, spec.version, spec.description) == ("machine", 1, "")
    assert spec.tool_mm == (0.0, 0.0, 0.0) and spec.workpiece_offset_mm == (0.0, 0.0, 0.0)
    assert spec.probe.tip_radius_mm == 0.0
    assert spec.axes == {} and spec.error_models == {} and spec.default_model is None
    m = Machine.from_spec(spec)
    assert m.model_name is None and m.n_params == 0
    # the workpiece-side axis moves the table (sign -1), the tool-side axes the tool
    assert [m.axes[a].sign for a in "XYZ"] == [-1.0, 1.0, 1.0]
    for a, unit in zip("XYZ", np.eye(3), strict=True):
        np.testing.assert_array_equal(m.axes[a].direction, unit)
        np.testing.assert_array_equal(m.axes[a].offset, [0.0, 0.0, 0.0])
        assert m.axes[a].travel is None and m.axes[a].resolution is None
        assert m.axes[a].basis.kind == "monomial" and not m.axes[a].basis.normalised


def test_axis_geometry_from_the_file():
    spec = parse_machine_spec(
        {
            "name": "m",
            "topology": "WCBXFZYST",
            "axes": {
                "X": {"direction": " -y ", "sign": 1, "travel_mm": [-10, 30]},
                "Y": {"direction": [0, 3, 4], "resolution_mm": 0.0005},
                "B": {"direction": "+Y", "travel_deg": [-90, 90], "resolution_deg": 0.001},
                "Z": {"offset_mm": [1, 2, 150]},
            },
            "tool_mm": [0, 0, -150],
            "workpiece_offset_mm": [5, 6, 7],
            "probe": {"tip_radius_mm": 2.9625},
        }
    )
    m = Machine.from_spec(spec)
    np.testing.assert_array_equal(m.axes["X"].direction, [0.0, -1.0, 0.0])
    np.testing.assert_allclose(m.axes["Y"].direction, [0.0, 0.6, 0.8], rtol=1e-15)
    np.testing.assert_array_equal(m.axes["B"].direction, [0.0, 1.0, 0.0])
    # rotary axes without a direction turn about their own letter: C about Z, S about Z
    np.testing.assert_array_equal(m.axes["C"].direction, [0.0, 0.0, 1.0])
    np.testing.assert_array_equal(m.axes["S"].direction, [0.0, 0.0, 1.0])
    assert m.axes["X"].sign == 1.0  # stated, although X is on the workpiece side
    assert m.axes["C"].sign == -1.0 and m.axes["B"].sign == -1.0 and m.axes["Z"].sign == 1.0
    assert m.axes["X"].travel == (-10.0, 30.0)
    assert m.axes["Y"].resolution == 0.0005
    b_low, b_high = m.axes["B"].travel
    assert from_internal(b_low, "deg") == pytest.approx(-90.0, rel=1e-15)
    assert from_internal(b_high, "deg") == pytest.approx(90.0, rel=1e-15)
    assert from_internal(m.axes["B"].resolution, "deg") == pytest.approx(0.001, rel=1e-15)
    np.testing.assert_array_equal(m.axes["Z"].offset, [1.0, 2.0, 150.0])
    np.testing.assert_array_equal(m.tool, [0.0, 0.0, -150.0])
    np.testing.assert_array_equal(m.workpiece_offset, [5.0, 6.0, 7.0])
    assert m.tip_radius == 2.9625


@pytest.mark.parametrize(
    ("axis", "field", "message"),
    [
        ("X", {"travel_deg": [0, 1]}, "axes.X.travel_deg: a linear axis takes travel_mm"),
        ("X", {"resolution_deg": 1}, "axes.X.resolution_deg: a linear axis takes resolution_mm"),
        ("B", {"travel_mm": [0, 1]}, "axes.B.travel_mm: a rotary axis takes travel_deg"),
        ("B", {"resolution_mm": 1}, "axes.B.resolution_mm: a rotary axis takes resolution_deg"),
    ],
)
def test_a_field_in_the_wrong_unit_for_the_axis_kind(axis, field, message):
    spec = parse_machine_spec({"name": "m", "topology": "WCBXFZYST", "axes": {axis: field}})
    with pytest.raises(MachineFileError) as err:
        Machine.from_spec(spec, source="m.yaml")
    assert str(err.value) == "m.yaml: " + message


def _machine_error(doc, model=None) -> str:
    with pytest.raises(MachineFileError) as err:
        Machine.from_spec(parse_machine_spec(doc), model=model, source="m.yaml")
    return str(err.value)


def test_machine_level_refusals():
    assert _machine_error({**BASE, "topology": "WXQT"}).startswith("m.yaml: topology: ")
    assert (
        _machine_error({**BASE, "axes": {"B": {}, "A": {}}})
        == "m.yaml: axes.A: axis not in topology WXFYZT"
    )
    models = {"a": {"parameters": ["E_X0Y"]}, "b": {"parameters": ["E_X0Z"]}}
    assert (
        _machine_error({**BASE, "error_models": models}, model="c")
        == "m.yaml: no error model 'c' (models: a, b)"
    )
    assert _machine_error(BASE, model="c") == "m.yaml: no error model 'c' (models: none)"
    assert (
        _machine_error({**BASE, "error_models": {"a": {"parameters": ["E_X0A"]}}})
        == "m.yaml: error_models: E_X0A refers to axis A, not in topology WXFYZT"
    )
    assert (
        _machine_error(
            {**BASE, "error_models": {"a": {"motions": {"E_XX": [1]}, "parameters": ["E_XX1"]}}}
        )
        == "m.yaml: error_models: E_XX1 is listed twice"
    )
    assert _machine_error({**BASE, "error_models": {"a": {"parameters": ["E_QQ1"]}}}).startswith(
        "m.yaml: error_models: "
    )
    assert (
        _machine_error({**BASE, "error_models": {"a": {"basis": "legendre", "motions": {}}}})
        == "m.yaml: axes.X: the legendre basis is normalised on the travel, so travel_mm "
        "is required"
    )


def test_error_models_and_their_bases():
    doc = {
        **BASE,
        "axes": {
            "X": {"travel_mm": [800, 1200]},
            "Y": {"travel_mm": [100, 500], "basis": "chebyshev"},
            "Z": {"travel_mm": [200, 400]},
        },
        "error_models": {
            "only": {
                "basis": "legendre",
                "motions": {" E_XX ": [1, 2], "E_YY": [1]},
                "parameters": ["E_C0Y"],
            }
        },
    }
    m = Machine.from_spec(parse_machine_spec(doc))
    # a single model is active without default_model; motions first, then parameters
    assert m.model_name == "only"
    assert m.parameter_names == ("E_XX1", "E_XX2", "E_YY1", "E_C0Y")
    assert (m.axes["X"].basis.kind, m.axes["Y"].basis.kind) == ("legendre", "chebyshev")
    assert (m.axes["X"].basis.centre, m.axes["X"].basis.half_range) == (1000.0, 200.0)
    assert (m.axes["Z"].basis.centre, m.axes["Z"].basis.half_range) == (300.0, 100.0)
    # normalise: false keeps a legendre basis on the raw reading (no travel needed)
    doc["error_models"]["only"]["normalise"] = False
    del doc["axes"]["Z"]
    m = Machine.from_spec(parse_machine_spec(doc))
    assert m.axes["Z"].basis.kind == "legendre" and not m.axes["Z"].basis.normalised
    # normalise: true on a monomial basis needs the travel
    doc["error_models"]["only"] = {"normalise": True, "parameters": ["E_C0Y"]}
    assert (
        _machine_error(doc)
        == "m.yaml: axes.Z: the monomial basis is normalised on the travel, so travel_mm "
        "is required"
    )
    doc["axes"]["Z"] = {"travel_mm": [200, 400]}
    m = Machine.from_spec(parse_machine_spec(doc))
    assert m.axes["X"].basis.kind == "monomial" and m.axes["X"].basis.centre == 1000.0


def test_a_rotary_axis_normalised_on_its_travel_in_degrees():
    doc = {
        "name": "m",
        "topology": "WCBXFZYST",
        "axes": {
            "B": {"travel_deg": [-90, 90]},
            **{a: {"travel_mm": [0, 100]} for a in "XYZ"},
        },
        "error_models": {"b": {"basis": "legendre", "normalise": False}},
    }
    m = Machine.from_spec(parse_machine_spec(doc))
    assert not m.axes["B"].basis.normalised
    doc["error_models"]["b"]["normalise"] = True
    assert (
        _machine_error(doc)
        == "m.yaml: axes.C: the legendre basis is normalised on the travel, so travel_deg "
        "is required"
    )


def test_default_model_and_explicit_model(tmp_path):
    m = Machine.load("five-axis-wcbxfzyst")
    assert m.model_name == "13"
    assert Machine.load("five-axis-wcbxfzyst", "84").n_params == 84


def test_load_machine_spec_from_a_file(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text("name: m\ntopology: WXFYZT\naxes:\n  X: {sign: 1}\n", encoding="utf-8")
    spec = load_machine_spec(path)
    assert spec.axes["X"].sign == 1
    assert Machine.load(path).axes["X"].sign == 1.0
    path.write_text("name: m\nname: n\ntopology: WXFYZT\n", encoding="utf-8")
    with pytest.raises(MachineFileError) as err:
        load_machine_spec(path)
    assert str(err.value).startswith(str(path))
    path.write_text("name: m\ntopology: WXFYZT\nsize: 3\n", encoding="utf-8")
    with pytest.raises(MachineFileError) as err:
        load_machine_spec(path)
    assert str(err.value).startswith(f"{path}: invalid machine definition: size:")


def test_the_description_of_a_minimal_machine():
    spec = parse_machine_spec(
        {**BASE, "axes": {"Y": {"offset_mm": [1, 2, 3]}, "Z": {"offset_mm": [0, 0, 10]}}}
    )
    d = machine_description(Machine.from_spec(spec))
    assert (d["model"], d["models"], d["tip_radius_mm"]) == (None, [], 0.0)
    x, y, z = d["axes"]
    assert (x["travel"], x["resolution"], x["unit"], x["basis"]) == (None, None, "mm", "monomial")
    # the reference point is the sum of the offsets from the frame F out to the axis
    assert x["reference_point_mm"] == [0.0, 0.0, 0.0]
    assert y["reference_point_mm"] == [1.0, 2.0, 3.0]
    assert z["reference_point_mm"] == [1.0, 2.0, 13.0]


def test_a_rotation_location_error_states_the_right_hand_rule():
    m = Machine.load("five-axis-wcbxfzyst")
    assert describe_parameter(m, "E_A0B").positive == (
        "turns the average line of axis B, with what it carries, by +E_A0B about +X "
        "(right-hand rule, machine frame)"
    )
    assert describe_parameter(m, "E_X0C").positive == (
        "moves the average line of axis C, with what it carries, by +E_X0C along +X (machine frame)"
    )


def test_errors_after_loading_a_file_name_the_file(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text("name: m\ntopology: WXFYZT\n", encoding="utf-8")
    with pytest.raises(MachineFileError) as err:
        Machine.load(path, model="c")
    assert str(err.value) == f"{path}: no error model 'c' (models: none)"
    with pytest.raises(MachineFileError) as err:
        Machine.load(tmp_path / "none.yaml")
    assert str(err.value).startswith(f"{tmp_path / 'none.yaml'}: neither a machine file nor a")


def test_readings_with_the_wrong_number_of_columns():
    m = Machine.load("three-axis-xfyz")
    with pytest.raises(ValueError) as err:
        m.readings_from_customary(np.zeros((2, 4, 5)))
    assert str(err.value) == "readings have 5 columns; this machine has axes XYZ"


def test_inverse_that_runs_out_of_iterations_raises():
    m = Machine.load("five-axis-wcbxfzyst")
    q0 = np.zeros(m.n_axes)
    with pytest.raises(ConvergenceError) as err:
        m.inverse([[10.0, 20.0, 30.0]], q0, max_iter=1)
    assert re.fullmatch(
        r"inverse kinematics did not converge \(residual \S+ mm at point 0 after 1 Newton "
        r"steps, tol 1e-12 mm; the iteration limit was reached\)",
        str(err.value),
    )
    # the same point, given alone (shape (3,)), has no index to name; more steps converge
    with pytest.raises(ConvergenceError, match=r"\(residual \S+ mm after 1 Newton steps"):
        m.inverse([10.0, 20.0, 30.0], q0, max_iter=1)
    back = m.inverse([10.0, 20.0, 30.0], q0)
    np.testing.assert_allclose(m.forward(back), [10.0, 20.0, 30.0], rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    ("points", "what"),
    [([[1.0, 2.0]], r"shape \(1, 2\)$"), ([[1.0, np.nan, np.inf]], r"NaN or inf in 2 coordinate")],
)
def test_inverse_refuses_unusable_points(points, what):
    m = Machine.load("five-axis-wcbxfzyst")
    with pytest.raises(
        InputError, match=rf"^points must be a finite \(\.\.\., 3\) array, mm; got {what}"
    ):
        m.inverse(points, np.zeros(m.n_axes))


def test_inverse_with_a_linear_axis_that_does_not_move_the_tool_raises():
    # E_XX1 = −1 mm/mm cancels the X motion (scale error: X reads x, moves x(1 + E_XX1)),
    # so ∂p/∂q has a zero column and the core's Cholesky factorisation fails
    m = Machine.load("five-axis-wcbxfzyst")
    theta = np.zeros(m.n_params)
    theta[m.parameter_names.index("E_XX1")] = -1.0
    with pytest.raises(ConvergenceError, match=r"^inverse kinematics: the position does not "):
        m.inverse([[10.0, 20.0, 30.0]], np.zeros(m.n_axes), theta)
    theta[m.parameter_names.index("E_XX1")] = -0.5
    back = m.inverse([[10.0, 20.0, 30.0]], np.zeros(m.n_axes), theta)
    np.testing.assert_allclose(m.forward(back, theta), [[10.0, 20.0, 30.0]], atol=1e-12)


def test_inverse_solves_each_point_with_its_own_parameters():
    # params of shape (T, 1, n) broadcast against (P, 3) points: T × P problems on the core
    m = Machine.load("five-axis-wcbxfzyst")
    rng = np.random.default_rng(3)
    theta = rng.normal(0.0, 1e-4, (4, 1, m.n_params))
    points = rng.uniform(-100.0, 100.0, (5, 3))
    q = m.inverse(points, np.zeros(m.n_axes), theta)
    assert q.shape == (4, 5, m.n_axes)
    np.testing.assert_allclose(m.forward(q, theta), np.broadcast_to(points, (4, 5, 3)), atol=1e-11)
