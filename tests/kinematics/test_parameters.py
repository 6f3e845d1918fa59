"""ISO 230-1 names, catalogue and units."""

import pytest

from mtmetrology.kinematics.parameters import (
    MAX_DEGREE,
    ParameterNameError,
    catalogue,
    coefficient_unit,
    parse_parameter,
)
from mtmetrology.kinematics.topology import parse_topology
from mtmetrology.units import to_internal


def test_names_parse_into_kind_axis_component_degree():
    p = parse_parameter("E_X0C")
    assert (p.kind, p.axis, p.component, p.degree) == ("location", "C", 0, None)
    p = parse_parameter("E_YZ2")
    assert (p.kind, p.axis, p.component, p.degree) == ("motion", "Z", 1, 2)
    p = parse_parameter("E_BBb")
    assert (p.kind, p.axis, p.component) == ("reversal", "B", 4)


@pytest.mark.parametrize(
    ("iso", "ascii_name"),
    [("E_A(0Z)B", "E_A0B"), ("E_X0(C1)", "E_X0S"), ("E_Y0C1", "E_Y0S"), ("E_B(0X)C", "E_B0C")],
)
def test_iso_spellings_of_the_sources_are_normalised(iso, ascii_name):
    assert parse_parameter(iso).name == ascii_name


@pytest.mark.parametrize("bad", ["EXX1", "E_QX1", "E_X0", "E_XX", "E_X0Q", "x"])
def test_bad_names(bad):
    with pytest.raises(ParameterNameError, match="ISO 230-1"):
        parse_parameter(bad)


def test_catalogue_counts_every_candidate():
    # per axis: 6 location + 6 components x (degree 0..3) + 6 reversal = 36
    assert len(catalogue(parse_topology("WCBXFZYST"))) == 6 * 36
    names = {p.name for p in catalogue(parse_topology("WCBXFZYST"))}
    assert {"E_X0C", "E_A0B", "E_X0S", "E_XX1", "E_YZ2", "E_BBb"} <= names


def test_units_follow_the_basis():
    assert coefficient_unit(parse_parameter("E_X0C"), normalised=False) == "µm"
    assert coefficient_unit(parse_parameter("E_A0B"), normalised=False) == "µrad"
    assert coefficient_unit(parse_parameter("E_XX1"), normalised=False) == "µm/m"
    assert coefficient_unit(parse_parameter("E_AX2"), normalised=False) == "µrad/m^2"
    assert coefficient_unit(parse_parameter("E_BB1"), normalised=False) == "µrad/rad"
    assert coefficient_unit(parse_parameter("E_XX3"), normalised=True) == "µm"
    # 75 µm/m is 75e-6 internally (ARCHITECTURE.md, units)
    assert to_internal(75.0, "µm/m") == pytest.approx(75e-6)
    assert to_internal(1.0, "µm/m^2") == pytest.approx(1e-9)


def test_the_catalogue_agrees_with_the_name_parser():
    """Every catalogue entry is what parsing its own name gives (axis, kind, component,
    degree), so the catalogue cannot attach a parameter to the wrong axis."""
    for p in catalogue(parse_topology("WCBXFZYST"), max_degree=2):
        assert parse_parameter(p.name) == p


def test_the_highest_degree_is_accepted_and_the_next_refused():
    assert parse_parameter("E_XX12").degree == MAX_DEGREE == 12
    with pytest.raises(ParameterNameError) as err:
        parse_parameter("E_XX13")
    assert str(err.value) == (
        "'E_XX13': degree 13 is beyond the highest error-motion degree supported (12)"
    )


def test_an_unknown_name_is_refused_with_the_three_forms():
    with pytest.raises(ParameterNameError) as err:
        parse_parameter("E_QQ1")
    assert str(err.value) == (
        "'E_QQ1' is not an ISO 230-1 error name: expected a location error such as "
        "'E_X0C', an error-motion coefficient such as 'E_XX1', or a reversal term such as "
        "'E_BBb'"
    )
