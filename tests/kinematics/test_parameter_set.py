"""Parameter-set files: units at the edge, covariance, validation."""

import json

import numpy as np
import pytest

from mtmetrology.io.files import InputFileError
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet


@pytest.fixture
def machine():
    return Machine.load("five-axis-wcbxfzyst")


def test_round_trip_converts_units_at_the_edge(tmp_path, machine):
    rng = np.random.default_rng(0)
    values = rng.normal(size=13) * 50 * machine.parameter_scales
    a = rng.normal(size=(13, 13))
    cov = (a @ a.T) * np.outer(machine.parameter_scales, machine.parameter_scales)
    pset = ParameterSet(machine.parameter_names, values, machine.parameter_units, cov)
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
        "parameters": [
            {"name": "E_X0C", "value": -0.1046, "unit": "mm", "u": 0.00048},
            {"name": "E_A(0Z)B", "value": -8.73e-3, "unit": "mrad", "u": 0.86e-3},
        ]
    }
    pset = ParameterSet.from_document(doc, machine)
    assert pset.names == ("E_X0C", "E_A0B")
    np.testing.assert_allclose(pset.values, [-0.1046, -8.73e-6])
    np.testing.assert_allclose(pset.standard_uncertainties, [0.00048, 0.86e-6])
    assert pset.units == ("µm", "µrad")


@pytest.mark.parametrize(
    ("entry", "message"),
    [
        ({"name": "E_QQ1", "value": 1, "unit": "µm"}, r"parameters\[0\]: 'E_QQ1' is not"),
        ({"name": "E_X0C", "value": 1, "unit": "µrad"}, r"unit 'µrad' does not fit"),
        ({"name": "E_X0C", "value": 1, "unit": "furlong"}, "unknown unit"),
        ({"name": "E_X0C", "value": "abc", "unit": "µm"}, "is not a number"),
        ({"name": "E_X0C", "value": float("nan"), "unit": "µm"}, "not finite"),
        ({"name": "E_X0A", "value": 1, "unit": "µm"}, "axis A, not in"),
    ],
)
def test_bad_parameter_entries_are_named(machine, entry, message):
    with pytest.raises(InputFileError, match=message):
        ParameterSet.from_document({"parameters": [entry]}, machine, "p.json")


def test_bad_covariance(machine):
    doc = {
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
