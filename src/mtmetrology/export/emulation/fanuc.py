"""FANUC pitch-error compensation, emulated from FANUC's parameter manual.

Semantics
---------
FANUC Series 0i-PB *Parameter Manual*, B-63980EN/01, §4 "Description of parameters",
parameters 3620–3627 and the examples on p. 100; FANUC Series 16i/18i-MA/TA technical
report A-77810E, "Bidirectional pitch error compensation", §2 table (a).

- **Where the points are.** 3620 is the number of the point at the reference position,
  3621/3622 the numbers of the extreme points on the − and + side, 3624 the interval
  between points (detection units); point n is at ``reference + (n − 3620) · 3624``.
- **What a value means.** p. 100: "The compensation value is output at the compensation
  position No. corresponding to each section between the coordinates": each point holds
  the *increment* of the compensation over the interval that ends at it, in detection
  units (1 µm, 0.001°) times the magnification 3623; the compensation at the reference
  position is zero.  The absolute compensation at a point is the running sum of the
  increments from the reference point (the figure "Pitch error compensation amount
  (absolute value)", p. 100).
- **Between points.** The control outputs an increment as pulses when the axis passes the
  point: constant between points (a staircase), the value of the point at or below the
  position.  **Outside** the extreme points the extreme values are held.
- **Rotary axis** (p. 100, example 2): the − extreme is the reference point, the + extreme
  ``3620 + 3625/3624``; "If the sum of the compensation value from 61 to 68 is not zero, the
  pitch error per rotation accumulates … For compensation position 60, set the same
  compensation value as for 68."  The table repeats every revolution.
- **Direction** (A-77810E, table (a)): with 3605#0 = 1, travel in the negative direction
  uses the points numbered from 3626 (same interval and count), whose absolute value at the
  reference position is 3627.
- **Sign.** See :data:`SEMANTICS`: the parameter manual states where and when the value
  is output, not whether a positive value moves the axis in the positive direction.

This module is the check of :mod:`mtmetrology.export.fanuc`; it shares no code with it.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.export.control import ControlTable

__all__ = ["SEMANTICS", "load"]

FILE = "fanuc_pitch.txt"
_DETECTION_UNIT = {"linear": 1e-3, "rotary": 1e-3 * np.pi / 180.0}  # mm, rad

SEMANTICS = {
    "value": "correction",
    "sign_established": False,
    "source": (
        "FANUC B-63980EN/01 p. 100 and A-77810E fix the points, increments, staircase, "
        "rotary closure and directions, but no sentence found ties the sign of the value "
        "to the measured error; taken as a correction added to the commanded position"
    ),
}


def _parse(text: str) -> tuple[dict, dict]:
    """Parameters ``{axis: {number: value}}`` and data ``{point: increment}``."""
    params: dict[str, dict[str, int]] = {}
    data: dict[int, int] = {}
    for k, raw in enumerate(text.splitlines(), start=1):
        line = raw.split(";", 1)[0].strip()
        if not line:
            continue
        f = line.split()
        try:
            if f[0].startswith("N") and len(f) == 2 and f[1].startswith("P"):
                point = int(f[0][1:]) - 10000
                if point < 0 or point in data:
                    raise ValueError
                data[point] = int(f[1][1:])
            elif len(f) == 3:
                params.setdefault(f[1], {})[f[0]] = int(f[2])
            else:
                raise ValueError
        except ValueError:
            raise InputError(f"{FILE}, line {k}: cannot read {raw!r}") from None
    return params, data


def _absolute(axis: str, data: dict, first: int, n: int, ref: int, at_ref: int) -> np.ndarray:
    """Absolute values of the ``n`` points numbered from ``first``: the running sum of the
    increments from the reference point (index ``ref``), ``at_ref`` there."""
    points = range(first, first + n)
    missing = [p for p in points if p not in data]
    if missing:
        raise InputError(f"{FILE}: axis {axis}: no value for point {missing[0]}")
    inc = np.array([data[p] for p in points], dtype=float)
    run = np.zeros(n)
    run[1:] = np.cumsum(inc[1:])  # the first point closes no interval of this table
    return run - run[ref] + at_ref


def load(files: Mapping[str, str], reference: Mapping[str, float]) -> list[ControlTable]:
    """The compensation each axis receives, from the parameters and the pitch-error data.

    Parameters
    ----------
    files : mapping of file name to text
        ``fanuc_pitch.txt``: ``NUMBER AXIS VALUE`` parameter lines and ``N… P…`` data.
    reference : mapping of axis to float
        Machine coordinate of each axis's reference position (internal units): where the
        point 3620 is.

    Returns
    -------
    list of ControlTable
        ``E_XX`` … per axis: positions, the compensation added (internal units) for travel
        in the positive and negative direction, staircase from the reference point.

    Raises
    ------
    InputError
        A line that cannot be read, a missing parameter or point, a rotary table whose
        increments do not close over one revolution.
    """
    if FILE not in files:
        raise InputError(f"{FILE}: not given")
    params, data = _parse(files[FILE])
    out = []
    for axis, p in params.items():
        where = f"{FILE}: axis {axis}"
        for number in ("3620", "3621", "3622", "3623", "3624"):
            if number not in p:
                raise InputError(f"{where}: parameter {number} not given")
        kind = "linear" if axis in "XYZ" else "rotary"
        if axis not in reference:
            raise InputError(f"{where}: not an axis of the machine")
        lo, hi, ref = p["3621"], p["3622"], p["3620"]
        if not lo <= ref <= hi:
            raise InputError(f"{where}: 3620 = {ref} is not within 3621–3622 ({lo}–{hi})")
        n = hi - lo + 1
        unit = _DETECTION_UNIT[kind] * p["3623"]
        forward = _absolute(axis, data, lo, n, ref - lo, 0)
        reverse = forward
        if p.get("3605#0") == 1:
            if "3626" not in p or "3627" not in p:
                raise InputError(f"{where}: 3605#0 = 1 needs 3626 and 3627")
            reverse = _absolute(axis, data, p["3626"], n, ref - lo, p["3627"])
        step = p["3624"] * _DETECTION_UNIT[kind]
        period = None
        if "3625" in p:
            period = p["3625"] * _DETECTION_UNIT["rotary"]
            if lo != ref or abs(n - 1 - period / step) > 1e-9:
                raise InputError(f"{where}: 3621 must be 3620 and 3622 = 3620 + 3625/3624")
            for name, values in (("positive", forward), ("negative", reverse)):
                if values[-1] != values[0]:
                    raise InputError(
                        f"{where}: the increments over one revolution ({name} direction) "
                        "do not sum to zero"
                    )
        q = reference[axis] + step * (np.arange(n) - (ref - lo))
        out.append(
            ControlTable(
                f"E_{axis}{axis}", q, forward * unit, reverse * unit, "staircase", period, ref - lo
            )
        )
    return out
