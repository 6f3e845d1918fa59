"""The Fanuc emulation against the parameter manual B-63980EN/01, p. 100.

Example 1 of p. 100 prints the compensation values of points 33–49 (reference point 40)
and the figure "Pitch error compensation amount (absolute value)": the absolute value at a
point is the running sum of the increments from the reference point, zero there.
"""

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.export.emulation import fanuc

INCREMENTS = [+2, +1, +1, -2, 0, -1, 0, -1, +2, +1, 0, -1, -1, -2, 0, +1, +2]  # points 33–49


def _text(increments, *, first=33, reference=40, interval=50000, extra=()):
    last = first + len(increments) - 1
    lines = [
        f"3620 X {reference}",
        f"3621 X {first}",
        f"3622 X {last}",
        "3623 X 1",
        f"3624 X {interval}",
        *extra,
    ]
    lines += [f"N{10000 + first + k} P{v:d}" for k, v in enumerate(increments)]
    return "\n".join(lines) + "\n"


def test_p100_example_absolute_values_are_running_sums_from_the_reference_point():
    """Point 41 gets +2 (its own increment), 42 +3, …; below the reference, point 39 is
    −(increment of 40) = +1, 35 is +4: the curve of the figure, in detection units (1 µm)."""
    (t,) = fanuc.load({"fanuc_pitch.txt": _text(INCREMENTS)}, {"X": 0.0})
    want = [2, 3, 4, 2, 2, 1, 1, 0, 2, 3, 3, 2, 1, -1, -1, 0, 2]
    np.testing.assert_allclose(t.forward, np.array(want) * 1e-3, atol=1e-15)
    assert t.forward[t.reference_index] == 0.0
    np.testing.assert_allclose(t.positions[[0, 7, -1]], [-350.0, 0.0, 450.0])


def test_between_points_the_value_is_held_as_a_staircase_and_beyond_the_ends_too():
    (t,) = fanuc.load({"fanuc_pitch.txt": _text(INCREMENTS)}, {"X": 0.0})
    got = t.correction(np.array([0.0, 49.9, 50.0, 1000.0, -1000.0]))
    np.testing.assert_allclose(got, np.array([0, 0, 2, 2, 2]) * 1e-3, atol=1e-15)


def test_rotary_increments_that_do_not_close_over_a_revolution_are_refused():
    """p. 100, example 2: "If the sum of the compensation value from 61 to 68 is not zero,
    the pitch error per rotation accumulates"."""
    inc = [1, 1, 0, 0, 0, 0, 0, 0, 1]  # points 60–68, sum over 61–68 = 1
    text = _text(inc, first=60, reference=60, interval=45000, extra=["3625 C 360000"])
    text = text.replace(" X ", " C ")
    with pytest.raises(InputError) as info:
        fanuc.load({"fanuc_pitch.txt": text}, {"C": 0.0})
    assert str(info.value) == (
        "fanuc_pitch.txt: axis C: the increments over one revolution (positive direction) "
        "do not sum to zero"
    )


def test_bidirectional_table_starts_from_3627_at_the_reference():
    """A-77810E table (a): the negative-direction points follow 3626, with the absolute
    value 3627 at the reference position."""
    text = _text([0, 1, 1], first=0, reference=0, interval=10000)
    text += "3605#0 X 1\n3626 X 3\n3627 X 6\nN10003 P0\nN10004 P1\nN10005 P1\n"
    (t,) = fanuc.load({"fanuc_pitch.txt": text}, {"X": 0.0})
    np.testing.assert_allclose(t.reverse - t.forward, 6e-3, atol=1e-15)


def test_a_missing_point_and_an_unreadable_line_are_named():
    text = _text(INCREMENTS).replace("N10035 P1\n", "")
    with pytest.raises(InputError) as info:
        fanuc.load({"fanuc_pitch.txt": text}, {"X": 0.0})
    assert str(info.value) == "fanuc_pitch.txt: axis X: no value for point 35"
    with pytest.raises(InputError) as info:
        fanuc.load({"fanuc_pitch.txt": _text(INCREMENTS).replace("N10035 P1", "N10035 Px")}, {})
    assert str(info.value) == "fanuc_pitch.txt, line 8: cannot read 'N10035 Px'"
