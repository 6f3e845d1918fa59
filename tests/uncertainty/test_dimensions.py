"""Tests for mtmetrology.uncertainty.dimensions (quantity calculus of model outputs)."""

from __future__ import annotations

from fractions import Fraction

import pytest

from mtmetrology.uncertainty.dimensions import Dimension, check_output_units
from mtmetrology.uncertainty.expressions import CompiledModel, ModelFileError

LENGTH, TEMPERATURE, TIME = (
    Dimension([1, 0, 0, 0]),
    Dimension([0, 1, 0, 0]),
    Dimension([0, 0, 1, 0]),
)


@pytest.mark.parametrize(
    ("unit", "exponents"),
    [
        ("nm", (1, 0, 0, 0)),
        ("°C", (0, 1, 0, 0)),
        ("/°C", (0, -1, 0, 0)),
        ("s", (0, 0, 1, 0)),
        ("hPa", (0, 0, 0, 1)),
        ("mm/s", (1, 0, -1, 0)),
        ("/s^2", (0, 0, -2, 0)),
        ("µrad", (0, 0, 0, 0)),
        ("µm/m", (0, 0, 0, 0)),
    ],
)
def test_dimension_of_unit_gives_the_base_exponents(unit, exponents):
    assert Dimension.of_unit(unit).exponents == tuple(Fraction(e) for e in exponents)


def test_dimension_algebra_multiplies_divides_and_raises():
    speed = LENGTH.times(TIME, -1)
    assert speed.exponents == (1, 0, -1, 0)
    assert str(speed) == "length·time^-1"
    assert str(LENGTH.times(LENGTH).power(Fraction(1, 2))) == "length"
    assert str(LENGTH.power(Fraction(3, 2))) == "length^3/2"
    assert LENGTH.times(LENGTH, -1).dimensionless
    assert Dimension.FREE.times(Dimension.FREE).free
    assert Dimension.FREE.times(LENGTH).same(LENGTH)
    assert not LENGTH.same(TEMPERATURE)
    assert Dimension.FREE.same(LENGTH) and LENGTH.same(Dimension.FREE)
    assert str(Dimension.FREE) == "dimensionless"


def _units_error(inputs, expression, input_units, output_unit=None):
    model = CompiledModel(inputs, [("y", expression)])
    with pytest.raises(ModelFileError) as info:
        check_output_units(model, input_units, [output_unit], "m.yaml")
    return str(info.value)


def test_gum_h1_end_gauge_model_is_a_length():
    """JCGM 100 H.1: l = l_s (1 + α_s θ) − ... with l_s in nm, α in /°C, θ in °C."""
    model = CompiledModel(
        ["l_s", "d", "alpha_s", "theta", "dalpha", "dtheta"],
        [("l", "l_s + d + l_s * (dalpha * theta + alpha_s * dtheta)")],
    )
    check_output_units(model, ["nm", "nm", "/°C", "°C", "/°C", "°C"], ["nm"], "h1.yaml")
    with pytest.raises(ModelFileError) as info:
        check_output_units(model, ["nm", "nm", "/°C", "°C", "/°C", "°C"], ["°C"], "h1.yaml")
    assert str(info.value) == (
        "h1.yaml: outputs.0 ('l'): unit '°C' is temperature but the expression is length "
        "(from the input units)"
    )


def test_sum_of_a_length_and_a_temperature_is_refused():
    assert _units_error(["l", "t"], "l + t", ["mm", "°C"]) == (
        "m.yaml: outputs.0 ('y'): '+' between a length and a temperature quantity; "
        "check the input units"
    )


def test_bare_number_takes_the_dimension_its_place_requires():
    model = CompiledModel(["t", "l"], [("y", "l * (t - 20) / t"), ("z", "2 - l / l")])
    check_output_units(model, ["°C", "mm"], ["mm", "1"], "m.yaml")


def test_functions_need_a_dimensionless_argument():
    assert _units_error(["l"], "exp(l)", ["mm"]) == (
        "m.yaml: outputs.0 ('y'): exp() of a length quantity (needs a dimensionless one); "
        "check the input units"
    )
    model = CompiledModel(["a", "l"], [("y", "l * sin(a)"), ("z", "arctan2(l, l)")])
    check_output_units(model, ["µrad", "mm"], ["mm", "rad"], "m.yaml")


def test_hypot_of_mixed_dimensions_and_variable_power_are_refused():
    msg = _units_error(["l", "t"], "hypot(l, t)", ["mm", "K"])
    assert msg.startswith("m.yaml: outputs.0 ('y'): hypot() of a length and a temperature")
    msg = _units_error(["l", "n"], "l ** n", ["mm", "1"])
    assert msg.startswith(
        "m.yaml: outputs.0 ('y'): a length quantity raised to a variable power has no dimension"
    )


def test_square_doubles_and_constant_power_multiplies_the_exponents():
    model = CompiledModel(["l", "s"], [("y", "square(l) / l"), ("z", "l ** 3 / (l * l) / s")])
    check_output_units(model, ["mm", "s"], ["m", "mm/s"], "m.yaml")


def test_undeclared_output_unit_is_not_compared():
    model = CompiledModel(["l", "t"], [("y", "l * t")])
    check_output_units(model, ["mm", "°C"], [None], "m.yaml")


def test_dimensioned_exponent_message():
    msg = _units_error(["a", "b"], "a ** b", ["m", "m"])
    assert msg.startswith("m.yaml: outputs.0 ('y'): an exponent must be dimensionless, not a ")
    assert msg.endswith(" quantity; check the input units")


def test_sqrt_halves_and_abs_keeps_dimension():
    model = CompiledModel(["a"], [("y", "sqrt(a * a)"), ("z", "abs(a)")])
    check_output_units(model, ["m"], ["m", "m"], "m.yaml")
    with pytest.raises(ModelFileError, match=r"^m\.yaml: outputs\.1 \('z'\): unit 's' is time"):
        check_output_units(model, ["m"], ["mm", "s"], "m.yaml")
