"""Tests for mtmetrology.uncertainty.conformity (ISO 14253-1:2017 decision rules).

The boundary cases use binary-exact numbers (multiples of 1/8) so that "at the limit"
is exact in floating point, and the next representable number on each side flips the
decision.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.uncertainty.conformity import Decision, Tolerance, decide

TWO_SIDED = Tolerance(10.0, -0.25, 0.5)  # LSL 9.75, USL 10.5
U = 0.125


def _after(x):
    return float(np.nextafter(x, math.inf))


def _before(x):
    return float(np.nextafter(x, -math.inf))


@pytest.mark.parametrize(
    ("value", "expected"),
    [
        (10.5 - U, Decision.CONFORMANCE),  # interval touches USL from inside
        (9.75 + U, Decision.CONFORMANCE),  # interval touches LSL from inside
        (_after(10.5 - U), Decision.UNDECIDED),
        (_before(9.75 + U), Decision.UNDECIDED),
        (10.5, Decision.UNDECIDED),  # at the limit itself
        (10.5 + U, Decision.UNDECIDED),  # interval touches USL from outside
        (9.75 - U, Decision.UNDECIDED),
        (_after(10.5 + U), Decision.NON_CONFORMANCE),
        (_before(9.75 - U), Decision.NON_CONFORMANCE),
        (10.0, Decision.CONFORMANCE),
    ],
)
def test_iso_14253_1_default_rule_at_the_boundaries(value, expected):
    assert decide(value, U, TWO_SIDED).decision is expected


def test_zones_are_the_specification_zone_reduced_and_extended_by_u():
    d = decide(10.0, U, TWO_SIDED)
    assert d.acceptance_zone == (9.875, 10.375)
    assert d.rejection_limits == (9.625, 10.625)
    assert d.conforms


def test_upper_only_tolerance_never_fails_on_the_open_side():
    flatness = Tolerance(0.0, None, 0.01)
    assert decide(-5.0, 0.002, flatness).decision is Decision.CONFORMANCE
    assert decide(0.008, 0.002, flatness).decision is Decision.CONFORMANCE
    assert decide(0.0105, 0.002, flatness).decision is Decision.UNDECIDED
    assert decide(0.0125, 0.002, flatness).decision is Decision.NON_CONFORMANCE
    doc = decide(0.0125, 0.002, flatness).to_dict()
    assert doc["tolerance"]["lower_limit"] is None and doc["acceptance_zone"][0] is None


def test_lower_only_tolerance():
    wall = Tolerance(2.0, 0.0, None)
    assert decide(1.875, 0.125, wall).decision is Decision.UNDECIDED
    assert decide(2.125, 0.125, wall).decision is Decision.CONFORMANCE
    assert decide(_before(1.875), 0.125, wall).decision is Decision.NON_CONFORMANCE


def test_asymmetric_interval_gives_asymmetric_zones():
    # Interval [y - 0.0625, y + 0.25]: the upper guard band is four times the lower.
    d = decide(10.25, (0.0625, 0.25), TWO_SIDED)
    assert d.acceptance_zone == (9.8125, 10.25)
    assert d.rejection_limits == (9.5, 10.5625)
    assert d.decision is Decision.CONFORMANCE
    assert decide(_after(10.25), (0.0625, 0.25), TWO_SIDED).decision is Decision.UNDECIDED
    assert decide(_after(10.5625), (0.0625, 0.25), TWO_SIDED).decision is (Decision.NON_CONFORMANCE)


def test_uncertainty_larger_than_the_tolerance_cannot_prove_conformance():
    d = decide(10.125, 1.0, TWO_SIDED)  # nominal-ish value, U = 1 > tolerance 0.75
    assert d.acceptance_zone[0] > d.acceptance_zone[1]
    assert d.decision is Decision.UNDECIDED
    assert decide(11.625, 1.0, TWO_SIDED).decision is Decision.NON_CONFORMANCE


def test_guard_band_factor_zero_is_simple_acceptance_and_half_shrinks_bands():
    assert decide(10.5, U, TWO_SIDED, guard_band_factor=0).decision is Decision.CONFORMANCE
    assert decide(_after(10.5), U, TWO_SIDED, guard_band_factor=0).decision is (
        Decision.NON_CONFORMANCE
    )
    d = decide(10.0, U, TWO_SIDED, guard_band_factor=0.5)
    assert d.acceptance_zone == (9.8125, 10.4375)


def test_to_dict_is_json_with_structured_fields():
    doc = json.loads(json.dumps(decide(10.6, U, TWO_SIDED, unit="mm").to_dict()))
    assert doc["kind"] == "conformity-decision" and doc["version"] == 1
    assert doc["decision"] == "undecided" and doc["unit"] == "mm"
    assert doc["tolerance"]["upper_limit"] == 10.5


def test_parse_tolerance_forms():
    t = Tolerance.parse("25, -0.010, 0.015")
    assert (t.nominal, t.lower_deviation, t.upper_deviation) == (25.0, -0.010, 0.015)
    assert Tolerance.parse("0,,0.01").lower_deviation is None
    assert Tolerance.parse("2,0,").upper_limit == math.inf


@pytest.mark.parametrize(
    "text", ["25", "25,-0.01", "a,b,c", ",0,1", "1,,", "1,0.5,-0.5", "1,nan,2"]
)
def test_bad_tolerance_text_raises_input_error_naming_the_option(text):
    with pytest.raises(InputError, match=r"^(--tolerance|tolerance)"):
        Tolerance.parse(text)


@pytest.mark.parametrize(
    ("value", "u", "h", "named"),
    [
        (math.nan, 0.1, 1.0, "value: expected a finite number"),
        (1.0, -0.1, 1.0, "expanded_uncertainty: must be >= 0"),
        (1.0, 0.1, -1.0, "guard_band_factor: must be >= 0"),
        (1.0, math.inf, 1, "expanded_uncertainty: expected a finite number"),
    ],
)
def test_bad_numbers_are_refused_naming_the_argument(value, u, h, named):
    with pytest.raises(InputError, match=f"^{named}"):
        decide(value, u, TWO_SIDED, guard_band_factor=h)
