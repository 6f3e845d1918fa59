"""Parameter-set files: units at the edge, covariance, validation."""

import json

import numpy as np
import pytest

from mtmetrology.io.files import InputFileError
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

HEADER = {"kind": "parameter-set", "version": 1, "machine": "five-axis-wcbxfzyst"}


@pytest.fixture
def machine():
    return Machine.load("five-axis-wcbxfzyst")


def test_round_trip_converts_units_at_the_edge(tmp_path, machine):
    rng = np.random.default_rng(0)
    values = rng.normal(size=13) * 50 * machine.parameter_scales
    a = rng.normal(size=(13, 13))
    cov = (a @ a.T) * np.outer(machine.parameter_scales, machine.parameter_scales)
    pset = ParameterSet(
        machine.parameter_names, values, machine.parameter_units, cov, machine=machine.name
    )
    for name in ("p.json", "p.yaml"):
        pset.save(tmp_path / name)
        back = ParameterSet.load(tmp_path / name, machine)
        np.testing.assert_allclose(back.values, values, rtol=1e-12)
        np.testing.assert_allclose(back.covariance, cov, rtol=1e-12)
    doc = json.loads((tmp_path / "p.json").read_text())
    e_xx1 = next(p for p in doc["parameters"] if p["name"] == "E_XX1")
    assert e_xx1["unit"] == "µm/m"
    assert e_xx1["value"] == pytest.approx(values[8] * 1e6)  # internal 1 -> µm/m


def test_other_units_of_the_same_dimension_are_converted(machine):
    doc = {
        **HEADER,
        "parameters": [
            {"name": "E_X0C", "value": -0.1046, "unit": "mm", "u": 0.00048},
            {"name": "E_A(0Z)B", "value": -8.73e-3, "unit": "mrad", "u": 0.86e-3},
        ],
    }
    pset = ParameterSet.from_document(doc, machine)
    assert pset.names == ("E_X0C", "E_A0B")
    np.testing.assert_allclose(pset.values, [-0.1046, -8.73e-6])
    np.testing.assert_allclose(pset.standard_uncertainty, [0.00048, 0.86e-6])
    assert pset.units == ("µm", "µrad")


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ({"name": "E_QQ1", "value": 1, "unit": "µm"}, r"parameters\[0\]: 'E_QQ1' is not"),
        ({"name": "E_X0C", "value": 1, "unit": "µrad"}, r"unit 'µrad' does not fit"),
        ({"name": "E_X0C", "value": 1, "unit": "furlong"}, "unknown unit"),
        ({"name": "E_X0C", "value": "abc", "unit": "µm"}, "is not a number"),
        ({"name": "E_X0C", "value": "12.5", "unit": "µm"}, "'12.5' is not a number"),
        ({"name": "E_X0C", "value": True, "unit": "µm"}, "True is not a number"),
        ({"name": "E_X0C", "value": 1, "unit": "µm", "sigma": 2}, "sigma: unknown key"),
        ({"name": "E_X0C", "value": float("nan"), "unit": "µm"}, "is not finite"),
        ({"name": "E_X0A", "value": 1, "unit": "µm"}, "axis A, not in"),
    ],
)
def test_bad_parameter_entries_are_named(machine, entry, message):
    with pytest.raises(InputFileError, match=message):
        ParameterSet.from_document({**HEADER, "parameters": [entry]}, machine, "p.json")


def test_bad_covariance(machine):
    doc = {
        **HEADER,
        "parameters": [
            {"name": "E_X0C", "value": 1, "unit": "µm"},
            {"name": "E_X0S", "value": 1, "unit": "µm"},
        ],
        "covariance": {"names": ["E_X0C", "E_X0S"], "matrix": [[1, 2], [2, 1]]},
    }
    with pytest.raises(InputFileError, match="not positive semi-definite"):
        ParameterSet.from_document(doc, machine)
    doc["covariance"]["matrix"] = [[1, 0.5], [0.4, 1]]
    with pytest.raises(InputFileError, match="not symmetric"):
        ParameterSet.from_document(doc, machine)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"kind": "parameters"}, "kind: 'parameters' is not a parameter set"),
        ({"kind": None}, "kind: None is not a parameter set"),
        ({"version": 99}, "version: 99 is not supported"),
        ({"version": True}, "version: True is not supported"),
        ({"machine": "cmm-moving-bridge"}, "made for machine 'cmm-moving-bridge'"),
        ({"machine": 5}, "machine: must be a string"),
        ({"model": "21-chebyshev"}, "error model '21-chebyshev' is not a model"),
        ({"comment": "x"}, "comment: unknown key"),
    ],
)
def test_the_header_is_checked_not_ignored(machine, change, message):
    """Issue 9: kind, version, machine, model and unknown keys were ignored."""
    doc = {**HEADER, "parameters": [{"name": "E_X0C", "value": 1, "unit": "µm"}], **change}
    with pytest.raises(InputFileError, match=message):
        ParameterSet.from_document(doc, machine, "p.json")


def test_a_missing_machine_is_refused(machine):
    doc = {
        "kind": "parameter-set",
        "version": 1,
        "parameters": [{"name": "E_X0C", "value": 1, "unit": "µm"}],
    }
    with pytest.raises(InputFileError, match="machine: missing"):
        ParameterSet.from_document(doc, machine, "p.json")


def test_the_sets_model_defines_the_basis(tmp_path):
    """A set made with a named model is evaluated under that model's bases, whatever model
    the machine was loaded with: the 84-coefficient set keeps its meaning."""
    m84 = Machine.load("five-axis-wcbxfzyst", "84")
    values = np.zeros(m84.n_params)
    values[m84.parameter_names.index("E_XX1")] = 1e-4
    ParameterSet(
        m84.parameter_names, values, m84.parameter_units, machine=m84.name, model="84"
    ).save(tmp_path / "p.json")
    base = Machine.load("five-axis-wcbxfzyst")
    pset = ParameterSet.load(tmp_path / "p.json", base)
    m = pset.machine_for(base)
    assert m.model_name == "84" and m.parameter_names == m84.parameter_names


def test_duplicate_keys_are_refused(tmp_path, machine):
    """Issue 9: a second key silently won."""
    text = (
        '{"kind": "parameter-set", "version": 1, "machine": "five-axis-wcbxfzyst", '
        '"parameters": [{"name": "E_X0C", "value": 1, "value": 2, "unit": "µm"}]}'
    )
    (tmp_path / "p.json").write_text(text)
    with pytest.raises(InputFileError, match="'value' appears twice"):
        ParameterSet.load(tmp_path / "p.json", machine)


def test_a_set_of_another_machine_is_refused_naming_both_machines_first():
    """Issue 29: a Legendre set of three-axis-xfyz (E_XX1 in µm) read for the five-axis
    machine (E_XX1 in µm/m) was refused with a unit message; the unit mismatch comes from
    the other machine, and the refusal says that first."""
    five = Machine.load("five-axis-wcbxfzyst")
    doc = {
        "kind": "parameter-set",
        "version": 1,
        "machine": "three-axis-xfyz",
        "model": "21-legendre",
        "parameters": [{"name": "E_XX1", "value": 10.0, "unit": "µm"}],
    }
    with pytest.raises(InputFileError) as err:
        ParameterSet.from_document(doc, five, "p.json")
    assert str(err.value).startswith(
        "p.json: made for machine 'three-axis-xfyz', not 'five-axis-wcbxfzyst' "
        "(parameters[0] (E_XX1): unit 'µm' does not fit"
    )
    doc["parameters"] = [{"name": "E_XX1", "value": 10.0, "unit": "µm/m"}]
    doc["machine"] = "five-axis-wcbxfzyst"
    del doc["model"]
    assert ParameterSet.from_document(doc, five, "p.json").names == ("E_XX1",)


def test_repr_shows_customary_units_with_u():
    """Issue 31: the repr showed ``values=array([3.90e-03, …]), units=('µm', …)`` (mm values
    labelled µm); now each value in its customary unit with u to two significant digits."""
    pset = ParameterSet(
        ("E_X0C", "E_A0B", "E_XX1"),
        np.array([-0.1045912, 3.9e-6, 7.94e-5]),
        ("µm", "µrad", "µm/m"),
        covariance=np.diag([7.34e-4, 1.8e-6, 5.2e-6]) ** 2,
        machine="m",
    )
    lines = repr(pset).splitlines()
    assert lines[0] == "ParameterSet(machine='m', 3 parameters:"
    assert [line.strip() for line in lines[1:]] == [
        "E_X0C = -104.59 µm, u = 0.73 µm",
        "E_A0B = 3.9 µrad, u = 1.8 µrad",
        "E_XX1 = 79.4 µm/m, u = 5.2 µm/m)",
    ]
    bare = repr(ParameterSet(("E_X0C",), np.array([0.0039]), ("µm",)))
    assert "E_X0C = 3.9 µm (no uncertainty)" in bare and "no covariance" in bare
