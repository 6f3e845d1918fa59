"""Tests for mtmetrology.uncertainty.modelfile (safe expressions, YAML schema)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mtmetrology.uncertainty.distributions import Normal, Rectangular, StudentT
from mtmetrology.uncertainty.modelfile import (
    ModelFileError,
    load_model,
    parse_model,
)

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "gum-h1-end-gauge.yaml"


def _doc(expression="a * b + c", **extra):
    doc = {
        "kind": "measurement-model",
        "inputs": [
            {"name": "a", "value": 2.0, "u": 0.1, "unit": "mm"},
            {
                "name": "b",
                "value": 3.0,
                "unit": "1",
                "distribution": {"kind": "rectangular", "a": 0.5},
            },
            {
                "name": "c",
                "unit": "mm",
                "distribution": {"kind": "student-t", "x": 1.0, "s": 0.2, "dof": 4},
            },
        ],
        "outputs": [{"name": "y", "expression": expression, "unit": "mm"}],
    }
    doc.update(extra)
    return doc


def test_example_file_loads_with_units_and_dof():
    m = load_model(EXAMPLE)
    assert m.inputs.names == ["l_s", "d", "alpha_s", "theta", "dalpha", "dtheta"]
    assert m.inputs.units[2] == "/°C"
    np.testing.assert_array_equal(m.inputs.dof, [18, 25.6, math.inf, math.inf, 50, 2])
    assert m.output_names == ["l"] and m.output_units == ["nm"]


def test_inputs_built_from_value_and_distribution():
    m = parse_model(_doc())
    qs = m.inputs.quantities
    assert qs[0].distribution == Normal(2.0, 0.1)
    assert qs[1].distribution == Rectangular(2.5, 3.5)
    assert qs[2].distribution == StudentT(1.0, 0.2, 4.0) and qs[2].effective_dof == 4.0


def test_compiled_model_is_vectorised():
    m = parse_model(_doc())
    x = np.random.default_rng(0).normal(size=(7, 5, 3))
    y = m.model(x)
    assert y.shape == (7, 5, 1)
    np.testing.assert_allclose(y[..., 0], x[..., 0] * x[..., 1] + x[..., 2])


def test_outputs_can_use_earlier_outputs_and_constant_outputs_broadcast():
    doc = _doc()
    doc["outputs"] = [
        {"name": "area", "expression": "pi * a**2 / 4"},
        {"name": "twice", "expression": "2 * area + 0 * a**2"},
        {"name": "k", "expression": "sqrt(2) * e"},
    ]
    m = parse_model(doc)
    y = m.model(np.array([[2.0, 1.0, 0.0], [4.0, 1.0, 0.0]]))
    np.testing.assert_allclose(
        y,
        [
            [math.pi, 2 * math.pi, math.sqrt(2) * math.e],
            [4 * math.pi, 8 * math.pi, math.sqrt(2) * math.e],
        ],
    )


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (
            lambda d: d["inputs"][0].update(value=float("nan")),
            r"inputs.0.value: Input should be a finite number",
        ),
        (
            lambda d: d["inputs"][0].update(u=-1.0),
            r"inputs.0.u: Input should be greater than or equal to 0",
        ),
        (lambda d: d["inputs"][0].update(dof=float("nan")), r"inputs.0.dof"),
        (
            lambda d: d["inputs"][0].update(colour="red"),
            r"inputs.0.colour: Extra inputs are not permitted",
        ),
        (
            lambda d: d["inputs"][1]["distribution"].update(kind="gaussian"),
            r"inputs.1 \('b'\).distribution: unknown distribution 'gaussian'; known kinds",
        ),
        (
            lambda d: d["inputs"][1]["distribution"].update(a=-0.5),
            r"inputs.1 \('b'\).distribution: a must be >= 0",
        ),
        (
            lambda d: d["inputs"][1]["distribution"].update(a=float("nan")),
            r"inputs.1 \('b'\).distribution: a must be finite, got nan",
        ),
        (
            lambda d: d["inputs"][2]["distribution"].update(low=0.0),
            r"value is given|unexpected parameter",
        ),
        (
            lambda d: d["inputs"][0].update(unit="furlong"),
            r"inputs.0 \('a'\): input 'a': unknown unit 'furlong'",
        ),
        (lambda d: d["inputs"][1].update(name="a"), r"duplicate input names"),
        (lambda d: d["inputs"][1].update(name="sqrt"), r"input name 'sqrt' is reserved"),
        (lambda d: d["inputs"][1].update(name="2x"), r"input name '2x' is not a valid identifier"),
        (lambda d: d.update(outputs=[]), r"outputs: List should have at least 1 item"),
        (lambda d: d.update(kind="machine"), r"kind: Input should be 'measurement-model'"),
        (
            lambda d: d["outputs"][0].update(unit="parsec"),
            r"outputs.0 \('y'\): unknown unit 'parsec'",
        ),
        (lambda d: d["outputs"][0].update(name="a"), r"output name 'a' is already used"),
        (
            lambda d: d.update(correlations=[{"inputs": ["a", "q"], "r": 0.5}]),
            r"correlations.0: unknown input 'q'",
        ),
        (
            lambda d: d.update(correlations=[{"inputs": ["a", "b"], "r": 1.5}]),
            r"correlations.0.r: Input should be less than or equal to 1",
        ),
        (
            lambda d: d.update(correlations=[{"inputs": ["a", "b"], "r": 0.5}]),
            r"'b' is Rectangular; correlations are supported between normal",
        ),
    ],
)
def test_bad_model_files_name_the_field(mutate, message):
    doc = _doc()
    mutate(doc)
    with pytest.raises(ModelFileError, match=message):
        parse_model(doc, "bad.yaml")


def test_correlated_normal_inputs_from_file():
    doc = _doc()
    doc["inputs"][1] = {"name": "b", "value": 3.0, "u": 0.2}
    doc["correlations"] = [{"inputs": ["a", "b"], "r": -0.5}]
    m = parse_model(doc)
    assert m.inputs.covariance[0, 1] == pytest.approx(-0.5 * 0.1 * 0.2)


def test_load_model_file_errors(tmp_path):
    with pytest.raises(ModelFileError, match=r"missing\.yaml: file not found"):
        load_model(tmp_path / "missing.yaml")
    p = tmp_path / "bad.yaml"
    p.write_text("inputs: [unclosed\n", encoding="utf-8")
    with pytest.raises(ModelFileError, match=r"bad\.yaml, line 2: not valid YAML"):
        load_model(p)
    p.write_text("- just\n- a list\n", encoding="utf-8")
    with pytest.raises(ModelFileError, match="must be a YAML mapping"):
        load_model(p)


def test_every_scalar_distribution_kind_from_a_file():
    doc = _doc()
    doc["inputs"] = [
        {"name": "t1", "distribution": {"kind": "triangular", "low": 0, "mode": 1, "high": 4}},
        {"name": "t2", "value": 2.0, "distribution": {"kind": "trapezoidal", "a": 1, "beta": 0.5}},
        {
            "name": "t3",
            "value": 0.0,
            "distribution": {"kind": "curvilinear-trapezoid", "a": 1, "d": 0.1},
        },
        {"name": "t4", "value": 5.0, "distribution": {"kind": "arcsine", "a": 2}},
        {"name": "t5", "distribution": {"kind": "samples", "values": [1, 2, 3, 6]}},
        {"name": "t6", "value": 1.0, "distribution": {"kind": "normal", "U": 0.4, "k": 2}},
    ]
    doc["outputs"] = [{"name": "y", "expression": "t1 + t2 + t3 + t4 + t5 + t6"}]
    m = parse_model(doc)
    np.testing.assert_allclose(m.inputs.estimate, [5 / 3, 2.0, 0.0, 5.0, 3.0, 1.0])
    assert m.inputs.standard_uncertainty[5] == pytest.approx(0.2)
    x = m.inputs.sample(np.random.default_rng(0), 1000)
    assert x.shape == (1000, 6) and set(np.unique(x[:, 4])) <= {1.0, 2.0, 3.0, 6.0}
    with pytest.raises(ModelFileError, match="inputs are scalar"):
        bad = _doc()
        bad["inputs"][0] = {
            "name": "a",
            "distribution": {"kind": "multivariate-normal", "mean": [0], "covariance": [[1]]},
        }
        parse_model(bad)
