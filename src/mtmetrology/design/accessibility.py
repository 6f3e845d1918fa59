"""Accessibility of a master ball at a rotary indexation: can the probe reach it?

Seed 004 names accessibility as a constraint of the SAMBA planning but gives no rule
(digest 004 §3.11, §7 item 18). The rule here checks, for ball i at indexation (B, C):

1. **travel**: the nominal readings that put the stylus centre on the ball centre
   (inverse kinematics of :class:`~mtmetrology.kinematics.Machine`) lie within every
   axis's travel;
2. **approach cone against the stem**: the probe shank, seen from the ball, makes at
   least ``stem_cone_deg`` with the ball's own stem (the stem runs from the ball down to
   the pallet along −z of the workpiece frame), so the equator and pole touches are free;
3. **table**: the lowest point of the probe (shank of length ``probe_length_mm`` from the
   stylus centre, radius ``probe_radius_mm``) stays ``clearance_mm`` above the pallet;
4. **other balls and stems**: the shank keeps ``clearance_mm`` from every other master
   ball (radius ``ball_diameter_mm``/2) and its stem (vertical cylinder of radius
   ``stem_radius_mm`` from the pallet to the ball centre).

The shank direction is the machine's own: the stylus centre and the spindle gauge point
(tool vector set to zero) are both computed with the kinematic engine at the nominal
readings, so any topology works. The probing cycle itself (5 touches about the ball)
is taken to need no more room than the stylus ball; the scale-bar tube is not an
obstacle (the bar is probed at two indexations only, where the set-up puts it clear).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from mtmetrology.design.inputs import load_validated
from mtmetrology.kinematics.machine import Machine
from mtmetrology.units import to_internal

__all__ = ["AccessibilityRule", "accessible", "load_accessibility_rule", "nominal_readings"]

_TERNARY_STEPS = 60  # golden-section steps: the bracket shrinks to 0.618^60 ≈ 3e-13


class AccessibilityRule(BaseModel):
    """Geometry of the probe, stems and clearances (YAML ``kind: accessibility-rule``).

    Attributes
    ----------
    check_travel : bool
        Refuse indexations whose readings leave an axis travel.
    stem_cone_deg : float
        Smallest angle between the probe shank and the ball's stem, degrees.
    probe_length_mm : float or None
        Shank length from the stylus centre; the machine's tool length when None.
    probe_radius_mm, stem_radius_mm : float
        Radii of the shank and of the stems, mm.
    ball_diameter_mm : float
        Master-ball diameter, mm (Ø19.05 mm in seed 004).
    clearance_mm : float
        Smallest free distance between the probe and the table, a stem or a ball, mm.
    table_z_mm : float
        Pallet top in the workpiece frame, mm.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    kind: str = Field(default="accessibility-rule", pattern="^accessibility-rule$")
    check_travel: bool = True
    stem_cone_deg: float = Field(default=30.0, ge=0.0, lt=180.0)
    probe_length_mm: float | None = Field(default=None, gt=0.0)
    probe_radius_mm: float = Field(default=3.0, ge=0.0)
    stem_radius_mm: float = Field(default=5.0, ge=0.0)
    ball_diameter_mm: float = Field(default=19.05, gt=0.0)
    clearance_mm: float = Field(default=2.0, ge=0.0)
    table_z_mm: float = 0.0


def load_accessibility_rule(path: str | Path) -> AccessibilityRule:
    """Read an accessibility-rule YAML file; errors name the file and the field."""
    return load_validated(path, "accessibility rule", AccessibilityRule)


def nominal_readings(machine: Machine, centres: np.ndarray, pairs_deg: np.ndarray) -> np.ndarray:
    """Nominal readings that put the stylus centre on each ball at each (B, C).

    Parameters
    ----------
    machine : Machine
        With rotary axes B and C (spindle S at 0).
    centres : ndarray, shape (n_balls, 3)
        Ball centres in the workpiece frame, mm.
    pairs_deg : ndarray, shape (N, 2)
        (B, C) indexations, degrees.

    Returns
    -------
    ndarray, shape (N, n_balls, n_axes), internal units (mm, rad)
    """
    pairs = np.asarray(pairs_deg, dtype=float)
    cols = {a: np.zeros((len(pairs), 1)) for a in machine.axis_names}
    cols["B"] = pairs[:, :1]
    cols["C"] = pairs[:, 1:2]
    guess = machine.readings_from_customary(cols)  # (N, 1, n_axes)
    target = np.asarray(centres, dtype=float)[None, :, :]
    return machine.inverse(target, guess)


def _point_to_vertical_segment(p, base, height):
    """Distance from points p (..., 3) to the vertical segments base + [0, height]·z."""
    d_xy = np.hypot(p[..., 0] - base[..., 0], p[..., 1] - base[..., 1])
    dz = p[..., 2] - base[..., 2]
    over = np.maximum(0.0, np.maximum(dz - height, -dz))
    return np.hypot(d_xy, over)


def _segment_to_vertical_segment(a, u, length, base, height):
    """Shortest distance from segments a + t·u, t ∈ [0, length], to vertical segments.

    The distance from a point moving along a segment to a convex set is convex in t, so
    a golden-section search finds its minimum (to 3e-13 of the length).
    """
    lo = np.zeros(np.broadcast_shapes(a.shape[:-1], base.shape[:-1]))
    hi = np.full_like(lo, float(length))
    ratio = (np.sqrt(5.0) - 1.0) / 2.0

    def dist(t):
        return _point_to_vertical_segment(a + t[..., None] * u, base, height)

    for _ in range(_TERNARY_STEPS):
        t1 = hi - ratio * (hi - lo)
        t2 = lo + ratio * (hi - lo)
        left = dist(t1) <= dist(t2)
        hi = np.where(left, t2, hi)
        lo = np.where(left, lo, t1)
    ends = np.minimum(dist(np.zeros_like(lo)), dist(np.full_like(hi, float(length))))
    return np.minimum(dist(0.5 * (lo + hi)), ends)


def accessible(
    machine: Machine,
    rule: AccessibilityRule,
    centres: np.ndarray,
    pairs_deg: np.ndarray,
    *,
    obstacles: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Which balls the probe can reach at which (B, C) indexations.

    Parameters
    ----------
    machine : Machine
    rule : AccessibilityRule
    centres : ndarray, shape (n_balls, 3)
        Master-ball centres in the workpiece frame, mm (stem from the pallet up to z).
    pairs_deg : ndarray, shape (N, 2)
        Candidate (B, C) indexations, degrees.
    obstacles : bool
        Check the other balls and stems (rule 4); off when the balls are candidates of
        which only a few will be mounted together (step 1 of a SAMBA design).

    Returns
    -------
    mask : ndarray of bool, shape (N, n_balls)
        True where ball j is probeable at indexation i.
    readings : ndarray, shape (N, n_balls, n_axes)
        Nominal readings (internal units).

    Examples
    --------
    A ball above the B/C intersection is reachable from above, not with the shank
    pointing down its stem (B = 180° turns the pallet upside down):

    >>> m = Machine.load("five-axis-wcbxfzyst")
    >>> rule = AccessibilityRule(check_travel=False)
    >>> mask, _ = accessible(m, rule, np.array([[0.0, 0.0, 100.0]]), np.array([[0, 0], [180, 0]]))
    >>> mask[:, 0].tolist()
    [True, False]
    """
    c = np.asarray(centres, dtype=float)
    q = nominal_readings(machine, c, pairs_deg)
    tip = machine.forward(q)
    gauge = machine.forward(q, tool=np.zeros(3))
    tool_length = float(np.linalg.norm(machine.tool))
    shank = (gauge - tip) / tool_length  # unit vector from stylus centre up the probe
    length = rule.probe_length_mm if rule.probe_length_mm is not None else tool_length
    ok = np.ones(q.shape[:2], dtype=bool)
    if rule.check_travel:
        for k, name in enumerate(machine.axis_names):
            travel = machine.axes[name].travel
            if travel is not None:
                eps = 1e-9 * max(1.0, abs(travel[0]), abs(travel[1]))
                ok &= (q[..., k] >= travel[0] - eps) & (q[..., k] <= travel[1] + eps)
    cone = float(to_internal(rule.stem_cone_deg, "deg"))
    ok &= -shank[..., 2] <= np.cos(cone) + 1e-12
    lowest = c[None, :, 2] + np.minimum(0.0, length * shank[..., 2]) - rule.probe_radius_mm
    ok &= lowest >= rule.table_z_mm + rule.clearance_mm
    if obstacles and len(c) > 1:
        n = len(c)
        base = np.column_stack([c[:, :2], np.full(n, rule.table_z_mm)])
        height = c[:, 2] - rule.table_z_mm
        a = c[None, :, None, :]  # (1, probed, 1, 3)
        u = shank[:, :, None, :]  # (N, probed, 1, 3)
        d_stem = _segment_to_vertical_segment(a, u, length, base[None, None], height[None, None])
        # point-to-segment distance of the other ball centres to the shank
        rel = c[None, None, :, :] - a
        t = np.clip(np.einsum("ijkl,ijkl->ijk", rel, u), 0.0, length)
        d_ball = np.linalg.norm(rel - t[..., None] * u, axis=-1)
        need_stem = rule.probe_radius_mm + rule.stem_radius_mm + rule.clearance_mm
        need_ball = rule.probe_radius_mm + 0.5 * rule.ball_diameter_mm + rule.clearance_mm
        # a clearance met exactly is met: decided to 1 nm, not by the rounding of the
        # kinematics (balls on a mm grid put stylus and stem exactly at the clearance)
        touch = 1e-6
        clash = (d_stem < need_stem - touch) | (d_ball < need_ball - touch)
        clash[:, np.arange(n), np.arange(n)] = False  # a ball is not its own obstacle
        ok &= ~np.any(clash, axis=2)
    return ok, q
