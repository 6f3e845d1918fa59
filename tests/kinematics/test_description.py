"""The machine description (what `mtm machine show` prints) and small public helpers,
checked field by field against the machine they describe."""

import numpy as np
import pytest

from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.conventions import describe_parameter, machine_description
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.kinematics.parameters import catalogue

PRESETS = [
    ("five-axis-wcbxfzyst", "13"),
    ("five-axis-wcbxfzyst", "84"),
    ("three-axis-xfyz", None),
    ("cmm-moving-bridge", None),
]


@pytest.mark.parametrize(("preset", "model"), PRESETS)
def test_description_document(preset, model):
    m = Machine.load(preset, model)
    doc = machine_description(m)
    assert doc["kind"] == "machine-description" and doc["version"] == 1
    assert doc["name"] == m.name
    for row, name, unit in zip(
        doc["parameters"], m.parameter_names, m.parameter_units, strict=True
    ):
        convention = describe_parameter(m, name)
        assert row == convention.to_dict()
        assert row["name"] == name and row["unit"] == unit and row["kind"] == convention.kind
        assert row["reference_point_mm"] == [float(v) for v in convention.reference_point_mm]
        if row["kind"] == "location" and row["name"][3] in "ABC":
            assert "right-hand rule, machine frame" in row["positive"]
        if row["kind"] != "location":
            assert row["reference"].startswith(("measured at", "acting about"))


def test_position_unit_of_error_motion_coefficients():
    """Monomial bases state the position unit (m or rad); normalised bases the variable
    u on [-1, 1]; degree-0 terms and location errors no position at all."""
    five = Machine.load("five-axis-wcbxfzyst", "84")
    assert describe_parameter(five, "E_XX1").positive.endswith("(x in m)")
    assert "(c in rad)" in describe_parameter(five, "E_CC1").positive
    assert "(" not in describe_parameter(five, "E_X0C").positive.split("machine frame")[-1]
    three = Machine.load("three-axis-xfyz")
    assert "normalised on the travel to [-1, 1]" in describe_parameter(three, "E_XX1").positive
    catalogue_three = Machine.load("three-axis-xfyz").with_parameters(["E_XX0"])
    assert "(" not in describe_parameter(catalogue_three, "E_XX0").positive


def test_rotation_parameters_act_about_their_reference_point():
    five = Machine.load("five-axis-wcbxfzyst", "84")
    assert describe_parameter(five, "E_CCb").reference.startswith("acting about the C")
    assert describe_parameter(five, "E_XX1").reference.startswith("measured at the X")


def test_zero_parameter_set_of_a_machine():
    m = Machine.load("five-axis-wcbxfzyst", "84")
    zero = ParameterSet.zeros(m)
    assert tuple(zero.names) == tuple(m.parameter_names)
    np.testing.assert_array_equal(zero.values, np.zeros(m.n_params))
    assert tuple(zero.units) == tuple(m.parameter_units)
    assert zero.machine == m.name and zero.model == m.model_name
    np.testing.assert_array_equal(zero.vector_for(m), np.zeros(m.n_params))


def test_machine_catalogue_is_the_topology_catalogue():
    m = Machine.load("three-axis-xfyz")
    assert m.catalogue(2) == catalogue(m.topology, 2)
    degrees = {p.degree for p in m.catalogue(2) if p.kind == "motion"}
    assert degrees == {0, 1, 2}
