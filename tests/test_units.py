"""mtmetrology.units: factors from their definitions, round trips, refusals.

The expected factors are the SI / ISO definitions written out here (1 in = 25.4 mm
exactly, 1° = π/180 rad, 1″ = π/648 000 rad), not values read back from the module.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mtmetrology.errors import InputError
from mtmetrology.units import Unit, UnitError, convert, from_internal, parse_unit, to_internal

# symbol -> (dimension, value of one unit in mm, rad, 1, °C, s or Pa), from the definitions
DEFINITIONS = {
    "m": ("length", 1000.0),
    "mm": ("length", 1.0),
    "um": ("length", 0.001),
    "µm": ("length", 0.001),  # micro sign U+00B5
    "μm": ("length", 0.001),  # Greek mu U+03BC
    "nm": ("length", 1e-6),
    "in": ("length", 25.4),
    "rad": ("angle", 1.0),
    "mrad": ("angle", 0.001),
    "urad": ("angle", 1e-6),
    "µrad": ("angle", 1e-6),
    "μrad": ("angle", 1e-6),
    "deg": ("angle", math.pi / 180.0),
    "°": ("angle", math.pi / 180.0),
    "arcsec": ("angle", math.pi / 648_000.0),
    '"': ("angle", math.pi / 648_000.0),
    "1": ("ratio", 1.0),
    "": ("ratio", 1.0),
    "ppm": ("ratio", 1e-6),
    "%": ("ratio", 0.01),
    "°C": ("temperature", 1.0),
    "degC": ("temperature", 1.0),
    "K": ("temperature", 1.0),
    "s": ("time", 1.0),
    "min": ("time", 60.0),
    "h": ("time", 3600.0),
    "Pa": ("pressure", 1.0),
    "hPa": ("pressure", 100.0),
    "kPa": ("pressure", 1000.0),
}


@pytest.mark.parametrize("symbol", sorted(DEFINITIONS))
def test_simple_units_carry_their_defined_factor(symbol):
    dimension, factor = DEFINITIONS[symbol]
    unit = parse_unit(symbol)
    assert unit == Unit(symbol, dimension, pytest.approx(factor, rel=1e-15))
    assert to_internal(1.0, symbol) == pytest.approx(factor, rel=1e-15)
    assert from_internal(factor, symbol) == pytest.approx(1.0, rel=1e-15)


@pytest.mark.parametrize(
    ("symbol", "dimension", "factor"),
    [
        ("µm/m", "ratio", 1e-6),  # ISO 230-1 squareness and scale errors
        ("mm/m", "ratio", 1e-3),
        ("µrad/rad", "ratio", 1e-6),
        ("µm/deg", "length/angle", 1e-3 / (math.pi / 180.0)),
        ("mm/rad", "length/angle", 1.0),
        ("µrad/mm", "angle/length", 1e-6),
        ("/°C", "1/temperature", 1.0),  # thermal expansion coefficients
        ("1/K", "1/temperature", 1.0),
        ("ppm/K", "1/temperature", 1e-6),
        ("µm/m^2", "length/length^2", 1e-3 / 1e6),
        ("µm/m²", "length/length^2", 1e-3 / 1e6),
        ("µrad/m³", "angle/length^3", 1e-6 / 1e9),
        ("µm/mm²", "length/length^2", 1e-3),  # a two-letter base before the superscript
        ("µm/m^1", "ratio", 1e-6),  # a first power is the plain quotient
    ],
)
def test_quotients_combine_dimension_and_factor(symbol, dimension, factor):
    unit = parse_unit(symbol)
    assert unit.dimension == dimension
    assert unit.factor == pytest.approx(factor, rel=1e-15)
    assert unit.symbol == symbol


def test_whitespace_is_ignored_and_the_symbol_kept_without_it():
    assert parse_unit("  µm / m ") == parse_unit("µm/m")
    assert parse_unit(" mm ").symbol == "mm"


def test_customary_values_of_iso_230_1():
    """75 µm/m is 75e-6; 12.5 µm is 0.0125 mm; 90° is π/2 rad; 1 in is 25.4 mm."""
    assert to_internal(75.0, "µm/m") == pytest.approx(75e-6, rel=1e-15)
    assert to_internal(12.5, "µm") == pytest.approx(0.0125, rel=1e-15)
    assert to_internal(90.0, "deg") == pytest.approx(math.pi / 2, rel=1e-15)
    assert convert(1.0, "in", "mm") == pytest.approx(25.4, rel=1e-15)
    assert convert(1.0, "m", "µm") == pytest.approx(1e6, rel=1e-15)
    assert convert(3600.0, "arcsec", "deg") == pytest.approx(1.0, rel=1e-15)
    assert convert(1.0, "mm/m", "µm/m") == pytest.approx(1000.0, rel=1e-15)


def test_arrays_stay_arrays_and_scalars_stay_scalars():
    values = np.array([[1.0, -2.0], [0.5, 4.0]])
    out = to_internal(values, "µm")
    assert isinstance(out, np.ndarray) and out.shape == (2, 2)
    np.testing.assert_allclose(out, values * 1e-3, rtol=1e-15)
    back = from_internal(out, "µm")
    assert isinstance(back, np.ndarray)
    np.testing.assert_allclose(back, values, rtol=1e-15)
    # plain Python floats (not numpy scalars) for scalars, ready for JSON and printing
    assert type(to_internal(2.0, "mm")) is float
    assert type(from_internal(2.0, "deg")) is float
    # a parsed Unit is accepted in place of its symbol
    assert to_internal(2.0, parse_unit("µm")) == pytest.approx(0.002, rel=1e-15)
    assert from_internal(0.002, parse_unit("µm")) == pytest.approx(2.0, rel=1e-15)


UNITS_BY_DIMENSION: dict[str, list[str]] = {}
for _symbol, (_dimension, _) in DEFINITIONS.items():
    UNITS_BY_DIMENSION.setdefault(_dimension, []).append(_symbol)
SAME_DIMENSION = st.sampled_from(sorted(UNITS_BY_DIMENSION)).flatmap(
    lambda d: st.tuples(
        st.sampled_from(UNITS_BY_DIMENSION[d]), st.sampled_from(UNITS_BY_DIMENSION[d])
    )
)
# values far from the subnormal range, where a factor of 1e-6 would lose digits
VALUES = st.floats(min_value=-1e9, max_value=1e9, allow_nan=False, allow_subnormal=False)


@settings(max_examples=200, deadline=None)
@given(pair=SAME_DIMENSION, value=VALUES)
def test_round_trips_through_internal_units_and_between_units(pair, value):
    a, b = pair
    assert from_internal(to_internal(value, a), a) == pytest.approx(value, rel=1e-14, abs=1e-300)
    there = convert(value, a, b)
    assert convert(there, b, a) == pytest.approx(value, rel=1e-14, abs=1e-300)
    # conversion is linear: the ratio of factors
    ratio = DEFINITIONS[a][1] / DEFINITIONS[b][1]
    assert there == pytest.approx(value * ratio, rel=1e-14, abs=1e-300)


@settings(max_examples=100, deadline=None)
@given(
    num=st.sampled_from(["µm", "mm", "nm", "µrad", "rad", "deg"]),
    den=st.sampled_from(["m", "mm", "rad", "deg", "°C"]),
    value=VALUES,
)
def test_quotient_round_trip(num, den, value):
    symbol = f"{num}/{den}"
    expected = DEFINITIONS[num][1] / DEFINITIONS[den][1]
    assert parse_unit(symbol).factor == pytest.approx(expected, rel=1e-15)
    assert from_internal(to_internal(value, symbol), symbol) == pytest.approx(
        value, rel=1e-14, abs=1e-300
    )


@pytest.mark.parametrize(
    "symbol", ["furlong", "µm/furlong", "furlong/m", "µm/m/s", "m^0", "µm/m^x", "µm/m^-1"]
)
def test_unknown_or_malformed_units_are_refused(symbol):
    with pytest.raises(UnitError) as err:
        parse_unit(symbol)
    assert symbol in str(err.value) or repr(symbol) in str(err.value)
    assert "\n" not in str(err.value)


@pytest.mark.parametrize(
    ("symbol", "named"),
    [
        ("furlong", "quotient such as 'µm/m'"),
        ("µm/furlong", "unknown unit 'furlong'"),
        ("furlong/m", "unknown unit 'furlong'"),
        ("µm/m/s", "at most one '/'"),
        ("µm/m^0", "the power '0' is not a positive integer"),
    ],
)
def test_refusals_say_what_is_wrong(symbol, named):
    with pytest.raises(UnitError) as err:
        parse_unit(symbol)
    assert named in str(err.value)


def test_a_unit_must_be_a_string():
    with pytest.raises(UnitError, match="must be a string, got float"):
        parse_unit(1.0)  # type: ignore[arg-type]


def test_conversion_between_dimensions_is_refused():
    with pytest.raises(UnitError) as err:
        convert(1.0, "µm", "µrad")
    assert "(length)" in str(err.value) and "(angle)" in str(err.value)
    # a unit error is an input error (the CLI turns it into exit code 2)
    assert isinstance(err.value, InputError) and isinstance(err.value, ValueError)


def test_units_are_frozen():
    unit = parse_unit("mm")
    with pytest.raises(AttributeError):
        unit.factor = 2.0  # type: ignore[misc]


def test_display_unit_of_internal_units_and_of_others():
    """Internal units show in the customary ISO 230-1 units; other units as given."""
    from mtmetrology.units import display_unit, internal_unit

    assert [display_unit(u) for u in ("mm", "rad", "mm/mm", "mm/mm^2", "rad/mm")] == [
        "µm", "µrad", "µm/m", "µm/m^2", "µrad/m",
    ]  # fmt: skip
    assert [display_unit(u) for u in ("nm", "1", "°C", "mg", "")] == ["nm", "1", "°C", "mg", ""]
    for customary in ("µm", "µrad", "µm/m", "µm/m^2", "µrad/rad"):
        inner = internal_unit(customary)
        assert parse_unit(inner).factor == 1.0  # an internal unit
        assert parse_unit(inner).dimension == parse_unit(customary).dimension
        assert display_unit(inner) == customary


def test_display_unit_of_tells_a_position_from_an_error():
    """Budget rows hold machine errors (µm, µrad) and axis readings (mm, degrees)."""
    from mtmetrology.units import POSITION_MM, READING_RAD, display_unit_of

    assert display_unit_of("mm", POSITION_MM) == "mm"
    assert display_unit_of("mm", -0.999 * POSITION_MM) == "µm"
    assert display_unit_of("rad", -READING_RAD) == "°"
    assert display_unit_of("rad", 0.999 * READING_RAD) == "µrad"
    assert display_unit_of("mm/mm", 1e3) == "µm/m"  # a ratio is never a position
    assert display_unit_of("nm", 5e6) == "nm"  # a file's own unit is kept
