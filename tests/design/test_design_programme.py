"""Tests for mtmetrology.design.programme (a SAMBA probing programme, its rows and its
predictions)."""

import numpy as np
import pytest
from lab_balls import LAB_CENTRES, LAB_IDS

from mtmetrology.design.accessibility import AccessibilityRule
from mtmetrology.design.inputs import ScaleBarPlacement, default_indexations
from mtmetrology.design.programme import (
    ProgrammeRows,
    approach_senses,
    check_sigma,
    evaluate_programme,
    fixed_programme_rows,
    order_indexations,
    per_tool,
)
from mtmetrology.errors import InputError

PAIRS = default_indexations()
FREE = AccessibilityRule(check_travel=False)


def test_approach_senses_cycle_through_the_four_combinations():
    np.testing.assert_array_equal(
        approach_senses(6), [[1, 1], [-1, 1], [1, -1], [-1, -1], [1, 1], [-1, 1]]
    )


def test_indexations_are_ordered_b_ascending_and_c_serpentine():
    pairs = np.array([[30, 0], [0, 90], [30, 45], [0, -90], [-30, 10], [0, 0]], float)
    np.testing.assert_array_equal(
        order_indexations(pairs),
        [[-30, 10], [0, 90], [0, 0], [0, -90], [30, 0], [30, 45]],
    )
    assert order_indexations(np.zeros((0, 2))).shape == (0, 2)


def test_fixed_rows_are_those_of_eq_5_14():
    """Every master ball at B = C = 0, both bar ends at (0°, 0°) and (0°, 90°), the first
    bar ball at S = 90°, 180°, 270°."""
    bar = ScaleBarPlacement()
    rows = fixed_programme_rows(bar, ["m1", "m2"])
    assert rows.balls == ["m1", "m2", "SB1", "SB2", "SB1", "SB2", "SB1", "SB1", "SB1"]
    np.testing.assert_array_equal(rows.c, [0, 0, 0, 0, 90, 90, 0, 0, 0])
    np.testing.assert_array_equal(rows.s, [0, 0, 0, 0, 0, 0, 90, 180, 270])
    np.testing.assert_array_equal(rows.sense_b, 1.0)


def test_rows_per_tool_repeat_the_programme_with_each_stylus():
    rows = fixed_programme_rows(ScaleBarPlacement(), ["m1"])
    assert per_tool(rows, 0) is rows
    both = per_tool(rows, 2)
    n = len(rows.balls)
    assert both.balls == rows.balls * 2
    np.testing.assert_array_equal(both.tool, [0] * n + [1] * n)
    np.testing.assert_array_equal(both.s, np.tile(rows.s, 2))
    mixed = ProgrammeRows.concat([rows, rows.with_tool(3)])
    np.testing.assert_array_equal(mixed.tool, [0] * n + [3] * n)


@pytest.mark.parametrize("sigma", [0.0, -1e-3, float("nan"), float("inf")])
def test_a_probing_sigma_that_is_not_positive_is_refused(sigma):
    with pytest.raises(InputError) as info:
        check_sigma(sigma)
    assert str(info.value) == f"probing sigma must be a positive number, got {sigma} mm"


@pytest.fixture(scope="module")
def programme(m13):
    return evaluate_programme(m13, LAB_IDS, LAB_CENTRES, PAIRS[::25], rule=FREE)


def test_the_programme_table_puts_the_stylus_on_each_ball(m13, programme):
    """X, Y, Z (with B, C, S) are the nominal readings that reach each ball centre."""
    header, rows = programme.table()
    assert header == ["ball", "B", "C", "S", "X", "Y", "Z"]
    assert len(rows) == programme.n_measurements
    bar = ScaleBarPlacement()
    centre = dict(zip(LAB_IDS, LAB_CENTRES, strict=True)) | dict(
        zip(bar.ends, bar.centres_mm, strict=True)
    )
    reached = m13.forward(programme.readings, None, tool=m13.tool)
    targets = np.array([centre[b] for b in programme.rows.balls])
    np.testing.assert_allclose(reached, targets, atol=1e-9)


def test_parameters_give_upf_as_u_over_sigma_and_u_scales_with_sigma(m13, programme):
    """u is linear in the noise: σ and the bar's u both doubled double every u."""
    rows = programme.parameters()
    assert [r["name"] for r in rows] == list(m13.parameter_names)
    for r in rows:
        assert r["upf"] == pytest.approx(r["u"] / 1.0)  # σ = 1 µm
    bar2 = ScaleBarPlacement(u_mm=0.002)
    double = evaluate_programme(
        m13, LAB_IDS, LAB_CENTRES, PAIRS[::25], rule=FREE, sigma_mm=0.002, bar=bar2
    )
    np.testing.assert_allclose(
        double.standard_uncertainty, 2 * programme.standard_uncertainty, rtol=1e-9
    )


def test_programme_rows_follow_eq_5_14_and_accessibility(m13):
    rule = AccessibilityRule()
    prog = evaluate_programme(m13, LAB_IDS, LAB_CENTRES, PAIRS[:40], rule=rule)
    bar = ScaleBarPlacement()
    r = prog.rows
    assert r.balls[:4] == LAB_IDS and np.all(r.b[:4] == 0) and np.all(r.c[:4] == 0)
    assert r.balls.count(bar.ends[0]) == 2 + 3 and sorted(r.s[r.s > 0]) == [90, 180, 270]
    # every indication lies within the travels
    for k, name in enumerate(m13.axis_names):
        lo, hi = m13.axes[name].travel
        assert np.all((prog.readings[:, k] >= lo - 1e-9) & (prog.readings[:, k] <= hi + 1e-9))
