"""The one rule for printed numbers: JCGM 100:2008, 7.2.6 (two significant digits of u)."""

import pytest

from mtmetrology.formatting import decimals_for, format_uncertainty, format_value


@pytest.mark.parametrize(
    ("u", "text"),
    [
        (0.095, "0.095"),  # already two digits
        (9.96, "10"),  # rounds up a decade: "10", not "10.0" (three digits)
        (0.996, "1.0"),
        (0.0995, "0.10"),
        (31.72, "32"),
        (0.001234, "0.0012"),
        (2.403635441, "2.4"),  # the validation table printed 2.403635441 µrad
        (0.009459852299, "0.0095"),  # the plan table printed 0.009459852299
        (9.96e-5, "1.0e-04"),  # scientific below 1e-4 keeps the second digit
        (0.0, "0"),
        (None, "—"),
    ],
)
def test_uncertainty_has_two_significant_digits(u, text):
    assert format_uncertainty(u) == text


@pytest.mark.parametrize(
    ("value", "u", "text"),
    [
        (50_000_838.62, 31.7, "50000839"),  # GUM H.1.6: l = 50 000 838 nm, u = 32 nm
        (100.02147, 0.00035, "100.02147"),  # GUM 7.2.2: m_s = 100.021 47 g, u_c = 0.35 mg
        (14.41022323, 0.0734, "14.410"),
        (1.23456, 9.96, "1"),  # the value follows the rounded u (10): units digit
        (-104.5912, 0.0734, "-104.591"),
    ],
)
def test_value_is_rounded_to_the_decimal_of_its_uncertainty(value, u, text):
    assert format_value(value, u) == text


def test_decimals_of_rounded_uncertainty_and_degenerate_u():
    assert [decimals_for(u) for u in (0.095, 9.96, 0.99)] == [3, 0, 2]
    # u = 0 or not finite: the value keeps its digits instead of a fake precision
    assert format_value(1.5, 0.0) == "1.5"
    assert format_value(1.5, float("nan")) == "1.5"


def test_small_uncertainty_values_are_scientific_to_the_place_of_u():
    """u below 1e-4 prints as 1.2e-06: the value follows in the same notation and place."""
    assert format_value(1.15e-05, 1.2e-06) == "1.15e-05"  # GUM H.1 α_s = 11.5e-6 /°C
    assert format_value(-9.587416744e-06, 1.8e-06) == "-9.6e-06"
    assert format_value(0.0, 5.8e-07) == "0"  # not 0.00000000
    assert format_value(3e-9, 1.2e-6) == "0"  # below the last digit of u


def test_large_value_with_small_tolerance_stays_fixed_point():
    """A validation row: 282.838772 mm against δ = 5.0e-05 mm, not 2.82838772e+02."""
    assert format_value(282.83877231, 5e-5) == "282.838772"
