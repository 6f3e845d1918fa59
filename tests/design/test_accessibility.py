"""Accessibility rule: travel, stem cone, table, other balls and stems."""

import numpy as np
import pytest

from mtmetrology.design.accessibility import (
    AccessibilityRule,
    accessible,
    load_accessibility_rule,
)
from mtmetrology.io.files import InputFileError
from mtmetrology.kinematics import Machine


@pytest.fixture(scope="module")
def machine():
    return Machine.load("five-axis-wcbxfzyst")


def test_a_tall_stem_in_the_shank_path_blocks_the_ball(machine):
    """At B = 90°, C = 0 the shank of this machine points along +x of the workpiece
    (horizontal, 150 mm): a 175 mm stem 80 mm along +x blocks the 75 mm ball behind it;
    from B = −90° the shank points away and the ball is free."""
    centres = np.array([[0.0, 0.0, 75.0], [80.0, 0.0, 175.0]])
    pairs = np.array([[90.0, 0.0], [-90.0, 0.0]])
    mask, _ = accessible(machine, AccessibilityRule(check_travel=False), centres, pairs)
    assert mask.tolist() == [[False, True], [True, True]]
    free, _ = accessible(
        machine, AccessibilityRule(check_travel=False), centres, pairs, obstacles=False
    )
    assert free.all()


def test_clearance_decides_at_the_stated_distance(machine):
    """Obstacle stem 30 mm beside the shank line: blocked when probe radius + stem radius +
    clearance exceeds 30 mm, free when below."""
    centres = np.array([[0.0, 0.0, 75.0], [80.0, 30.0, 175.0]])
    pairs = np.array([[90.0, 0.0]])

    def reachable(clearance):
        rule = AccessibilityRule(
            check_travel=False, probe_radius_mm=3, stem_radius_mm=5, clearance_mm=clearance
        )
        return bool(accessible(machine, rule, centres, pairs)[0][0, 0])

    assert not reachable(23.0) and reachable(21.0)
    assert reachable(22.0) and not reachable(22.001)


@pytest.mark.parametrize(("short_by_mm", "free"), [(1e-12, True), (1e-3, False)])
def test_a_clearance_met_to_rounding_is_met(machine, short_by_mm, free):
    """3 + 5 + 22 = 30 mm needed beside the shank: a stem short of it by rounding (1e-12 mm,
    the kinematics' own error on a mm grid) does not block; short by 1 µm it does."""
    centres = np.array([[0.0, 0.0, 75.0], [80.0, 30.0 - short_by_mm, 175.0]])
    rule = AccessibilityRule(
        check_travel=False, probe_radius_mm=3, stem_radius_mm=5, clearance_mm=22
    )
    assert bool(accessible(machine, rule, centres, np.array([[90.0, 0.0]]))[0][0, 0]) is free


def test_travel_limits_refuse_readings_outside(machine):
    """A ball 250 mm from the C axis needs X beyond the -220 mm travel at C = 180°."""
    centres = np.array([[250.0, 0.0, 75.0]])
    pairs = np.array([[0.0, 0.0], [0.0, 180.0]])
    mask, q = accessible(machine, AccessibilityRule(), centres, pairs)
    x = q[:, 0, machine.axis_names.index("X")]
    lo, hi = machine.axes["X"].travel
    assert mask[:, 0].tolist() == [bool(lo <= v <= hi) for v in x]
    assert not mask.all()


def test_rule_file_is_read_strictly(tmp_path):
    good = tmp_path / "rule.yaml"
    good.write_text("kind: accessibility-rule\nstem_cone_deg: 45\nclearance_mm: 1\n")
    assert load_accessibility_rule(good).stem_cone_deg == 45
    bad = tmp_path / "bad.yaml"
    bad.write_text("kind: accessibility-rule\nclearance: 1\n")
    with pytest.raises(InputFileError) as err:
        load_accessibility_rule(bad)
    assert "clearance" in str(err.value) and "bad.yaml" in str(err.value)
