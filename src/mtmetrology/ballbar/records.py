"""Ballbar test records: the neutral CSV and the test conditions, validated at the door.

A circular test (ISO 230-4) runs the tool round a circle of radius R about a centre in
one plane of two linear axes, once counter-clockwise and once clockwise; a telescoping
ballbar between a pivot on the table and a ball at the tool reads the change of the
distance between them.  The neutral file holds one row per sample::

    angle_deg, direction, reading_um, X, Y, Z

``angle_deg``
    the angle θ of the commanded point in the plane, from the plane's first axis towards
    its second (``XY``: from +X towards +Y; ``YZ``: from +Y towards +Z; ``ZX``: from +Z
    towards +X, the right-hand rule about the plane's normal);
``direction``
    ``ccw`` (θ increasing) or ``cw`` (θ decreasing);
``reading_um``
    ℓ = ‖P_tool − P_pivot‖ − R, the bar's length change from R, µm (positive: longer);
``X, Y, Z``
    the commanded axis readings, mm: the centre plus R (cos θ e₁ + sin θ e₂).

The conditions (plane, R, feed, centre, arc of overshoot) come with the file, not in it.
The file holds the data arc only (the overshoot arcs before and after are not recorded)
and both directions over the full circle: a gap in angle, a missing direction, angles
that do not advance in the run's direction, or a commanded point off the stated circle is
refused with one line naming the file, the line and what is missing.

No instrument's own export format is read: none of the ballbar makers documents its file
layout publicly (Renishaw's ``.b5r``/``.b5x`` files are undocumented), so no reader
could cite its source.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.units import from_internal, to_internal

__all__ = [
    "PLANES",
    "BallbarConditions",
    "BallbarTest",
    "nominal_test",
    "read_ballbar",
    "write_ballbar",
]

#: The planes of a circular test: (first axis, second axis), right-handed about the normal.
PLANES = {"XY": ("X", "Y"), "YZ": ("Y", "Z"), "ZX": ("Z", "X")}
_COLUMNS = ("angle_deg", "direction", "reading_um", "X", "Y", "Z")
_DIRECTIONS = {"ccw": 1, "cw": -1}
#: A step in angle larger than this many times the run's median step is a gap.
GAP_FACTOR = 1.5
#: Largest distance (mm) of a commanded point from the stated circle.
COMMAND_TOLERANCE_MM = 1e-3


@dataclass(frozen=True)
class BallbarConditions:
    """The conditions of one circular test (ISO 230-4:2005, clause 5 and Annex A lists).

    Attributes
    ----------
    plane : {"XY", "YZ", "ZX"}
    radius : float
        Nominal radius R (the calibrated bar length), mm.
    feed : float
        Contouring feed, mm/min.
    centre : (3,) ndarray
        Commanded axis readings of the circle centre (X, Y, Z), mm.
    overshoot : float
        Arc of overshoot before and after the data arc, rad.
    name : str
        Test id (nuisance unknowns are named by it).
    """

    plane: str
    radius: float
    feed: float
    centre: np.ndarray = field(repr=False)
    overshoot: float = 0.0
    name: str = "test"

    def __post_init__(self):
        if self.plane not in PLANES:
            raise InputError(f"plane {self.plane!r}: expected one of {', '.join(PLANES)}")
        for what, v in (("radius", self.radius), ("feed", self.feed)):
            if not (np.isfinite(v) and v > 0):
                raise InputError(f"the {what} must be a positive number, got {v}")
        c = np.asarray(self.centre, dtype=float)
        if c.shape != (3,) or not np.all(np.isfinite(c)):
            raise InputError(f"the centre must be three finite readings X,Y,Z (mm), got {c}")
        if not (np.isfinite(self.overshoot) and self.overshoot >= 0):
            raise InputError(f"the arc of overshoot must be ≥ 0, got {self.overshoot}")
        object.__setattr__(self, "centre", c)

    @property
    def axes(self) -> tuple[str, str]:
        """The plane's two axes (first, second)."""
        return PLANES[self.plane]

    @property
    def basis(self) -> np.ndarray:
        """(2, 3) unit vectors e₁, e₂ of the plane in X, Y, Z."""
        return np.eye(3)[["XYZ".index(a) for a in self.axes]]

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "plane": self.plane,
            "radius_mm": self.radius,
            "feed_mm_per_min": self.feed,
            "centre_mm": self.centre.tolist(),
            "overshoot_deg": float(from_internal(self.overshoot, "deg")),
        }


@dataclass(frozen=True, eq=False)
class BallbarTest:
    """One circular test: conditions and samples (internal units: mm, rad).

    Attributes
    ----------
    conditions : BallbarConditions
    angle : (n,) ndarray
        θ of each sample, rad, in [0, 2π).
    direction : (n,) int ndarray
        +1 counter-clockwise, −1 clockwise.
    reading : (n,) ndarray
        ℓ, mm.
    commanded : (n, 3) ndarray
        Commanded X, Y, Z readings, mm.
    lines : (n,) int ndarray
        File line of each sample (1-based; 0 for a virtual test).
    source : str
    """

    conditions: BallbarConditions
    angle: np.ndarray = field(repr=False)
    direction: np.ndarray = field(repr=False)
    reading: np.ndarray = field(repr=False)
    commanded: np.ndarray = field(repr=False)
    lines: np.ndarray = field(repr=False)
    source: str = ""

    def __len__(self) -> int:
        return int(self.angle.size)

    def with_reading(self, reading: np.ndarray) -> BallbarTest:
        """The same test with other readings ℓ (mm), e.g. a simulated one."""
        r = np.asarray(reading, dtype=float)
        if r.shape != self.angle.shape:
            raise InputError(f"{r.size} readings for {self.angle.size} samples")
        return BallbarTest(
            self.conditions, self.angle, self.direction, r, self.commanded, self.lines, self.source
        )


def _commanded(conditions: BallbarConditions, angle: np.ndarray) -> np.ndarray:
    e = conditions.basis
    return conditions.centre + conditions.radius * (
        np.cos(angle)[:, None] * e[0] + np.sin(angle)[:, None] * e[1]
    )


def nominal_test(conditions: BallbarConditions, n_per_run: int = 360) -> BallbarTest:
    """The samples of a test at ``n_per_run`` equal steps per direction, readings zero.

    The counter-clockwise run goes θ = 0 … 2π − Δ, the clockwise run back from 2π − Δ
    (as 0 − Δ) … 0, so both runs see every angle once.
    """
    if n_per_run < 8:
        raise InputError(f"a circular test needs at least 8 samples per run, got {n_per_run}")
    ccw = np.arange(n_per_run) * (2.0 * np.pi / n_per_run)
    angle = np.concatenate([ccw, ccw[::-1]])
    direction = np.repeat([1, -1], n_per_run)
    return BallbarTest(
        conditions,
        angle,
        direction,
        np.zeros(angle.size),
        _commanded(conditions, angle),
        np.zeros(angle.size, dtype=int),
        f"virtual {conditions.name}",
    )


def _check_run(path, lines, angle, sense: int, name: str) -> None:
    """Angles advance in the run's direction and cover the circle without a gap."""
    steps = np.diff(angle) * sense
    back = np.flatnonzero(steps <= 0)
    if back.size:
        k = back[0] + 1
        raise InputError(
            f"{path}, line {lines[k]}: angle_deg does not advance in the {name} run "
            f"({float(from_internal(angle[k - 1], 'deg')):g} then "
            f"{float(from_internal(angle[k], 'deg')):g})"
        )
    wrap = 2.0 * np.pi - (angle[-1] - angle[0]) * sense
    all_steps = np.append(steps, wrap)
    typical = np.median(steps)
    gap = np.flatnonzero(all_steps > GAP_FACTOR * typical)
    if gap.size:
        k = int(gap[0])
        start = float(from_internal(angle[k], "deg"))
        end = float(from_internal(angle[(k + 1) % angle.size], "deg"))
        raise InputError(
            f"{path}, line {lines[k]}: gap in angle in the {name} run: nothing between "
            f"{start:g}° and {end:g}° (steps are {float(from_internal(typical, 'deg')):g}°; "
            "a circular test covers the full circle)"
        )


def read_ballbar(path: str | Path, conditions: BallbarConditions) -> BallbarTest:
    """Read and validate a neutral ballbar CSV (columns in the module notes).

    Parameters
    ----------
    path : str or Path
    conditions : BallbarConditions

    Returns
    -------
    BallbarTest
        Counter-clockwise samples first, each run in file order.

    Raises
    ------
    InputError
        A missing column or non-numeric cell (named by line), a direction other than
        ``cw``/``ccw``, a missing direction, fewer than 8 samples in a run, angles that
        do not advance, a gap in angle, or a commanded point off the stated circle.
    """
    from mtmetrology.io.tables import read_csv_table

    table = read_csv_table(path, required=_COLUMNS)
    words = [w.lower() for w in table.strings("direction")]
    bad = next((i for i, w in enumerate(words) if w not in _DIRECTIONS), None)
    if bad is not None:
        raise InputError(
            f"{path}, line {table.lines[bad]}: direction {words[bad]!r}: expected ccw or cw"
        )
    direction = np.array([_DIRECTIONS[w] for w in words], dtype=int)
    for name, sense in _DIRECTIONS.items():
        count = int(np.sum(direction == sense))
        if count == 0:
            raise InputError(
                f"{path}: no {name} run: ISO 230-4 tests both directions (circular "
                "hysteresis H compares them)"
            )
        if count < 8:
            raise InputError(f"{path}: the {name} run has {count} samples; at least 8 needed")
    degrees = table.floats("angle_deg", bounds=(-720.0, 720.0), unit="deg")
    reading = to_internal(table.floats("reading_um", unit="µm"), "µm")
    commanded = table.vectors("XYZ")
    angle = np.mod(to_internal(degrees, "deg"), 2.0 * np.pi)
    order = np.concatenate([np.flatnonzero(direction == 1), np.flatnonzero(direction == -1)])
    for name, sense in _DIRECTIONS.items():
        rows = np.flatnonzero(direction == sense)
        # unwrap: a run that crosses 0° keeps advancing
        _check_run(path, table.lines[rows], np.unwrap(angle[rows]), sense, name)
    off = np.linalg.norm(commanded - _commanded(conditions, angle), axis=1)
    worst = int(np.argmax(off))
    if off[worst] > COMMAND_TOLERANCE_MM:
        raise InputError(
            f"{path}, line {table.lines[worst]}: commanded X,Y,Z is {off[worst]:.4g} mm off the "
            f"stated circle ({conditions.plane}, R = {conditions.radius:g} mm, centre "
            f"{', '.join(f'{v:g}' for v in conditions.centre)}): check the conditions"
        )
    return BallbarTest(
        conditions,
        angle[order],
        direction[order],
        reading[order],
        commanded[order],
        table.lines[order],
        str(path),
    )


def write_ballbar(test: BallbarTest, path: str | Path) -> None:
    """Write a test as the neutral CSV (atomically)."""
    from mtmetrology.io.tables import write_csv_table

    deg = from_internal(test.angle, "deg")
    um = from_internal(test.reading, "µm")
    words = {1: "ccw", -1: "cw"}
    rows = [
        [f"{deg[i]:.6f}", words[int(test.direction[i])], f"{um[i]:.6f}"]
        + [f"{v:.6f}" for v in test.commanded[i]]
        for i in range(len(test))
    ]
    write_csv_table(path, _COLUMNS, rows)
