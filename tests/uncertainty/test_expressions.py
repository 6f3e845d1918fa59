"""Tests for mtmetrology.uncertainty.expressions (safe expressions, analytic Jacobians)."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mtmetrology.uncertainty.expressions import (
    FUNCTIONS,
    Call,
    CompiledModel,
    ExpressionError,
    ModelFileError,
    check_identifier,
    compile_expressions,
)


def _compile(expression, source="<model>"):
    return CompiledModel(["a", "b", "c"], [("y", expression)], source=source)


def test_shared_output_is_one_node_evaluated_once():
    """An output reused by later outputs is the same node (linear, not exponential, cost)."""
    outputs = [("y0", "a")] + [(f"y{i}", f"y{i - 1} + y{i - 1}") for i in range(1, 60)]
    model = compile_expressions(["a"], outputs)
    assert model.trees[2].left is model.trees[1] and model.trees[2].right is model.trees[1]
    y = model(np.array([1.0]))
    assert y[-1] == 2.0**59
    assert model.jacobian(np.array([3.0]))[-1, 0] == 2.0**59


def test_constants_are_folded_and_pi_e_are_known():
    model = compile_expressions(["a"], [("y", "a * (2 * pi) + e ** 0")])
    root = model.trees[0]
    assert root.left.right.value == 2 * math.pi and root.right.value == 1.0
    np.testing.assert_allclose(model(np.array([0.5])), [math.pi + 1.0])


def test_model_refuses_x_of_the_wrong_width():
    model = _compile("a + b + c")
    with pytest.raises(ValueError) as info:
        model(np.ones((4, 2)))
    assert str(info.value) == "model expects X with last axis 3, got shape (4, 2)"


def test_names_properties_and_repr():
    model = compile_expressions(["a", "b"], [("s", "a + b"), ("d", "s - b")], ["mm", "mm"])
    assert model.input_names == ["a", "b"]
    assert model.output_names == ["s", "d"]
    assert model.expressions == ["a + b", "s - b"]
    assert model.output_units == ["mm", "mm"]
    assert repr(model) == "CompiledModel(s = a + b, d = s - b)"
    np.testing.assert_array_equal(model(np.array([2.0, 5.0])), [7.0, 2.0])


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("pi", "m.yaml: input name 'pi' is reserved"),
        ("sqrt", "m.yaml: input name 'sqrt' is reserved"),
        ("__x", "m.yaml: input name '__x' is reserved"),
        ("lambda", "m.yaml: input name 'lambda' is not a valid identifier"),
        ("1a", "m.yaml: input name '1a' is not a valid identifier"),
    ],
)
def test_check_identifier_refuses_reserved_and_invalid_names(name, message):
    with pytest.raises(ModelFileError) as info:
        check_identifier(name, "input", "m.yaml")
    assert str(info.value) == message


def test_duplicate_output_and_empty_model_are_refused():
    with pytest.raises(ModelFileError) as info:
        CompiledModel(["a"], [("a", "2 * a")], source="m.yaml")
    assert str(info.value) == "m.yaml: output name 'a' is already used"
    with pytest.raises(ModelFileError) as info:
        CompiledModel(["a"], [], source="m.yaml")
    assert str(info.value) == "m.yaml: a model needs at least one output"


def test_non_finite_constant_is_refused():
    with pytest.raises(ExpressionError) as info:
        _compile("a + 10 ** 400", "m.yaml")
    assert str(info.value) == (
        "m.yaml: output 'y': the constant 10 ** 400 is not a finite number (column 5)"
    )


def test_output_identifier_message_names_output():
    with pytest.raises(ModelFileError) as info:
        CompiledModel(["a"], [("class", "a")], source="m.yaml")
    assert str(info.value) == "m.yaml: output name 'class' is not a valid identifier"


def _expression_error(expression):
    with pytest.raises(ModelFileError) as info:
        CompiledModel(["a"], [("y", expression)], source="m.yaml")
    return str(info.value)


def test_syntax_error_shows_expression_of_exactly_sixty_characters():
    expression = "a + " + "b" * 54 + " +"
    assert len(expression) == 60
    assert _expression_error(expression) == (
        f"m.yaml: output 'y': syntax error in {expression!r}: invalid syntax"
    )


def test_too_deep_expression_message():
    assert _expression_error("-" * 205 + "a") == (
        "m.yaml: output 'y': nested 208 levels deep, more than 200; define intermediate outputs"
    )


def test_forbidden_binary_operator_message_has_column():
    assert _expression_error("a % 2") == (
        "m.yaml: output 'y': operator in 'a % 2' is not allowed (use + - * / **) (column 1)"
    )


def test_derivative_drops_multiplication_by_one():
    model = CompiledModel(["a"], [("y", "exp(a)")])
    program = model._jacobian_program()
    root = program.steps[program.roots[0]][0]
    assert isinstance(root, Call) and root.func == "exp"
    assert len(program.steps) == 2
    assert model.jacobian(np.array([0.0]))[..., 0, 0] == pytest.approx(1.0)


ALL_FUNCTIONS = (
    "sqrt(a) + exp(b / 10) + log(a) + log10(b) + log1p(a) + expm1(b / 10) + sin(a) + cos(b)"
    " + tan(a / 3) + arcsin(a / 5) + arccos(b / 5) + arctan(a) + sinh(a / 3) + cosh(b / 3)"
    " + tanh(a) + abs(a - b) + sign(a) + square(b) + radians(a) + degrees(b)"
    " + arctan2(a, b) + hypot(a, b) + a ** b + a ** 2.5 / b - (-c) ** 3"
)


def test_every_whitelisted_function_is_used_in_the_jacobian_test():
    for name in FUNCTIONS:
        assert f"{name}(" in ALL_FUNCTIONS


@settings(max_examples=30, deadline=None)
@given(st.floats(1.0, 3.0), st.floats(1.2, 4.0), st.floats(-2.0, 2.0))
def test_symbolic_jacobian_matches_central_differences(a, b, c):
    """Symbolic derivatives of every whitelisted function against 5-point differences."""
    model = CompiledModel(["a", "b", "c"], [("y", ALL_FUNCTIONS), ("z", "a / (b + c**2)")])
    x = np.array([a, b, c])
    jac = model.jacobian(x)
    assert jac.shape == (2, 3)
    h = 1e-4
    num = np.empty((2, 3))
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        num[:, i] = (-model(x + 2 * e) + 8 * model(x + e) - 8 * model(x - e) + model(x - 2 * e)) / (
            12 * h
        )
    np.testing.assert_allclose(jac, num, rtol=1e-6, atol=1e-6)


def test_jacobian_is_vectorised():
    model = CompiledModel(["a", "b"], [("y", "a * b"), ("z", "a + 1")])
    x = np.array([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0]])
    j = model.jacobian(x)
    assert j.shape == (3, 2, 2)
    np.testing.assert_array_equal(j[:, 0, 0], [2.0, 4.0, 6.0])
    np.testing.assert_array_equal(j[:, 1], np.tile([1.0, 0.0], (3, 1)))


def test_pickle_round_trip_rebuilds_from_source():
    m = _compile("hypot(a, c) - c", "model.yaml")
    clone = pickle.loads(pickle.dumps(m))
    x = np.random.default_rng(3).normal(size=(4, 3))
    np.testing.assert_array_equal(clone(x), m(x))
    np.testing.assert_array_equal(clone.jacobian(x), m.jacobian(x))
    assert clone.expressions == ["hypot(a, c) - c"]
    assert b"hypot(a, c) - c" in pickle.dumps(m)


@pytest.mark.parametrize(
    ("expression", "message"),
    [
        (
            "__import__('os').system('true')",
            r"call to '__import__' is not allowed; allowed functions: sqrt",
        ),
        ("np.os", r"attribute access 'np.os' is not allowed"),
        ("a + __builtins__", r"name '__builtins__' is not allowed"),
        ("a.real + b", r"attribute access 'a.real' is not allowed"),
        ("a[0] + b", r"subscript 'a\[0\]' is not allowed"),
        ("open(a)", r"call to 'open' is not allowed"),
        ("eval('1')", r"call to 'eval' is not allowed"),
        ("(lambda: 1)()", r"call of 'lambda: 1' is not allowed"),
        ("a if b else c", r"IfExp 'a if b else c' is not allowed"),
        ("a < b", r"Compare 'a < b' is not allowed"),
        ("a // b", r"operator in 'a // b' is not allowed"),
        ("x + a", r"unknown name 'x'; known names: a, b, c, e, pi"),
        ("sqrt", r"function 'sqrt' must be called"),
        ("sqrt(a, b)", r"sqrt\(\) takes 1 argument\(s\), got 2"),
        ("hypot(a, y=b)", r"positional arguments only"),
        ("'text'", r"constant 'text' is not a real number"),
        ("a +", r"syntax error"),
        ("[a, b]", r"List '\[a, b\]' is not allowed"),
    ],
)
def test_unsafe_expressions_are_refused_naming_file_output_and_token(expression, message):
    with pytest.raises(ExpressionError, match=r"^model.yaml: output 'y': .*" + message):
        _compile(expression, "model.yaml")


def test_expression_errors_report_the_column():
    with pytest.raises(
        ExpressionError, match=r"attribute access 'np.os' is not allowed \(column 5\)"
    ):
        _compile("a + np.os", "m.yaml")
