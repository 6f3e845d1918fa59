"""Topology strings: parsing, source variants and errors."""

import pytest

from mtmetrology.kinematics.topology import TopologyError, parse_topology


@pytest.mark.parametrize(
    ("text", "workpiece", "tool"),
    [
        ("WCBXFZYST", ("X", "B", "C"), ("Z", "Y", "S")),
        ("WXFYZT", ("X",), ("Y", "Z")),
        ("WFYXZT", (), ("Y", "X", "Z")),
        ("wCBXbZY(C1)t", ("X", "B", "C"), ("Z", "Y", "S")),  # seed 004 Ch. 5 spelling
        ("wCBXfZY(C1)t", ("X", "B", "C"), ("Z", "Y", "S")),  # seed 004 Fig. A.1 spelling
    ],
)
def test_branches_read_from_the_frame_outwards(text, workpiece, tool):
    t = parse_topology(text)
    assert t.workpiece_axes == workpiece
    assert t.tool_axes == tool


def test_reading_order_is_linear_then_rotary_then_spindle():
    assert parse_topology("WCBXFZYST").axes == ("X", "Y", "Z", "B", "C", "S")
    assert parse_topology("WFYXZT").axes == ("X", "Y", "Z")


def test_parent_and_side():
    t = parse_topology("WCBXFZYST")
    assert t.parent("X") == "F" and t.parent("C") == "B" and t.parent("S") == "Y"
    assert t.side("B") == "workpiece" and t.side("Y") == "tool"
    with pytest.raises(TopologyError, match="not in topology"):
        t.side("A")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("WCBQFZYT", "unknown letter"),
        ("WXXFYZT", "repeated axis X"),
        ("CBXFZYST", "exactly one W"),
        ("WCBXZYST", "exactly one F"),
        ("WCBXFZYS", "exactly one T"),
        ("TXFYZW", "must start with W"),
        ("", "non-empty"),
    ],
)
def test_bad_topologies_say_what_is_wrong(text, message):
    with pytest.raises(TopologyError, match=message):
        parse_topology(text)


def test_unknown_letters_are_all_listed():
    with pytest.raises(TopologyError) as err:
        parse_topology("WQXFYJT")
    assert str(err.value) == (
        "topology 'WQXFYJT': unknown letter(s) 'J', 'Q'; use W (workpiece), F (frame), "
        "T (tool), X Y Z (linear), A B C (rotary), S (spindle)"
    )
