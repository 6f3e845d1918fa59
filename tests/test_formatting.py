"""The one rule for printed numbers: JCGM 100:2008, 7.2.6 (two significant digits of u)."""

import numpy as np
import pytest

from mtmetrology.formatting import (
    budget_cells,
    decimals_for,
    format_cell,
    format_result,
    format_signed,
    format_uncertainty,
    format_value,
    overstated_digits,
)


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


# --------------------------------------------------------------------------------------
# issue 31: one formatter for every number a person reads


def test_result_names_u_and_u_with_k_gum_7_2_2():
    """JCGM 100:2008, 7.2.2: "m_s = 100.021 47 g with u_c = 0.35 mg"; 7.2.4 states U with k."""
    assert format_result(100.02147, 0.00035, "g", name="m_s") == "m_s = 100.02147 g, u = 0.00035 g"
    assert (
        format_result(100.02147, 0.00035, "g", name="m_s", k=2)
        == "m_s = 100.02147 g, u = 0.00035 g, U = 0.00070 g (k = 2)"
    )


def test_result_in_mm_with_u_in_um_keeps_the_decimal_of_u():
    """The issue's ``l_x = 532.014299 mm, u = 2.06 µm``: u = 2.1 µm is 0.0021 mm, so the
    value has four decimals; U = k u with k = 1.96 stated as such."""
    text = format_result(532.014299, 2.06, "mm", name="l_x", u_unit="µm", k=1.96, p=0.95)
    assert text == "l_x = 532.0143 mm, u = 2.1 µm, U = 4.0 µm (k = 1.96, p ≈ 95 %)"
    assert overstated_digits(text) == []


def test_uncertainty_of_a_hundred_or_more_has_two_significant_digits():
    """The 84-parameter plan printed ``u = 9579, U = 18774``: two digits are 9600, 19000."""
    assert [format_uncertainty(u) for u in (9579.0, 18774.0, 101.0, 250.0)] == [
        "9600",
        "19000",
        "100",
        "250",
    ]
    assert format_value(123456.0, 9579.0) == "123500"


def test_no_negative_zero_anywhere():
    """``E_BBb -0 µrad`` and ``-0.00`` in correlation tables: a number that rounds to zero
    has no sign, whatever the formatter."""
    assert format_value(-0.3, 31.0) == "0"
    assert format_value(-0.004, 0.31) == "0.00"
    assert format_cell(-0.0) == "0"
    assert format_signed(-0.0004) == "0.00"
    assert format_signed(-0.005, 2) in ("-0.01", "0.01", "0.00")  # never "-0.00"
    assert format_signed(-0.005, 2) != "-0.00"


def test_budget_sensitivity_of_rounding_size_is_zero():
    """A sensitivity of -2.776e-17 (the output does not depend on the input) prints 0."""
    from mtmetrology.uncertainty.guf import BudgetRow

    rows = [
        BudgetRow("a", "", 1.0, 0.5, 1.0, 0.5, float("inf"), 1.0),
        BudgetRow("b", "", 2.0, 0.3, -2.776e-17, 8.3e-18, float("inf"), 0.0),
    ]
    lines, _ = budget_cells(rows, "")
    assert [line[4] for line in lines] == ["1", "0"]
    assert lines[1][5] == "0"


def test_overstated_digits_finds_each_breach_and_passes_the_formatter():
    """The digits test of issue 31 catches each example of the issue and none of what
    :func:`format_result` writes."""
    bad = {
        "iso15530-3 result 108.001825 mm, u = 2.9 µm": "value with more decimals",
        "u = 9579, U = 18774 µrad/m^3 (k = 2)": "u with more than two",
        "history: E_X0C 1.9000 ± 0.3 µm": "± without naming",
        "E_BBb -0 µrad": "-0 printed",
        "corr -0.00": "-0 printed",
        "U = 3.6 µrad": "U without k",
    }
    for text, what in bad.items():
        assert any(p.startswith(what) for p in overstated_digits(text)), text
    rng = np.random.default_rng(31)
    good = [
        format_result(v, u, "mm", name="x", u_unit="µm", k=2)
        for v, u in zip(rng.normal(0, 300, 200), 10 ** rng.uniform(-2, 3, 200), strict=True)
    ]
    assert overstated_digits("\n".join(good)) == []
