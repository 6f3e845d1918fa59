"""Fanuc pitch-error compensation: increments per interval, parameters 3620–3625.

Format (FANUC Series 0i-PB *Parameter Manual* B-63980EN/01, §4 "Description of
parameters", parameters 3620–3625 and the two examples on p. 100; FANUC Series 16i/18i
technical report A-77810E "Bidirectional pitch error compensation", table (a)):

- 3620 number of the compensation point at the reference position, 3621 / 3622 numbers
  of the extreme points on the − and + side, 3623 magnification, 3624 interval between
  points, 3625 travel per revolution of a rotary axis;
- each point holds the *increment* of the compensation over the interval that ends at it,
  in detection units times the magnification, not the absolute value; the compensation at
  the reference position is zero;
- the control outputs the increment when the axis passes the point (incremental
  accumulation: constant between points);
- rotary axis: the − extreme is the reference point, the + extreme is
  reference + 3625/3624, the increments over one revolution must sum to zero ("otherwise
  the pitch error per rotation accumulates"), and the reference point takes the value of
  the last one.

Data are written as ``N(10000 + number) P(value)`` lines, the form of the pitch-error
data in the control's punch/read files (cnc.wiki, *Setup Guide for Fanuc Pitch Error
Compensation Parameters*, "N_ P_ ; data tape upload"), after the parameters.  Detection
unit: 1 µm (linear) and 0.001° (rotary) (IS-B).  Only positioning errors of an axis's own
direction are carried (``E_XX`` … ``E_CC``).

Bidirectional pitch-error compensation (A-77810E, §2 table (a)), written when the parameter
set has a reversal term (``E_XXb``): 3605#0 = 1 enables it; the points of the positive
direction keep 3621/3622, those of the negative direction follow from 3626 (same interval
and count, here numbered right after the positive table); 3627 is the compensation
(absolute value) at the reference position for the negative direction.  Both tables share
one zero, the positive-direction value at the reference position, so 3627 carries the
reversal there; the increments of the negative table accumulate from it.  We write 3627 in
the units of the data (detection unit × 3623) and, as for the positive direction, model the
increment as output when the axis passes its point.

Semantics
---------
- **Value**: increments of the compensation per interval (B-63980EN/01 p. 100, "The
  compensation value is output at the compensation position No. corresponding to each
  section between the coordinates"), detection units × 3623; absolute value zero at the
  reference position; constant between points; the extreme values held beyond them.
- **Sign**: not fixed by a sentence of the parameter manual or of A-77810E that we could
  cite.  The table holds corrections (the value added to the commanded position, −E), and
  the export says "sign not established by the vendor's documentation", with the
  verification procedure that settles it on the machine.
- **Direction**: A-77810E table (a) (3605#0, 3626, 3627) as above.
- The emulation the export's residual comes from is
  :mod:`mtmetrology.export.emulation.fanuc`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.export._common import corrections, select
from mtmetrology.export.control import ControlTable
from mtmetrology.export.model import CompensationModel, ErrorTable
from mtmetrology.kinematics.topology import LINEAR_AXES

__all__ = ["MAX_POINTS", "build", "increments", "reference_notes", "render"]

NAME = "fanuc"
#: Compensation points shared by all axes (FANUC Series 16/18: 1024, numbers 0–1023).
MAX_POINTS = 1024
_DEG = np.pi / 180.0
_UNIT = {"linear": 1e-3, "rotary": 1e-3 * _DEG}  # detection unit in mm / rad


def _carries(table: ErrorTable) -> str | None:
    if table.component != table.axis:
        return "pitch-error compensation corrects an axis's own position only"
    return None


def _rotary(model: CompensationModel, axis: str) -> bool:
    travel = model.machine.axes[axis].travel
    return axis not in LINEAR_AXES and abs(travel[1] - travel[0] - 2 * np.pi) < 1e-9


def increments(absolute: np.ndarray) -> np.ndarray:
    """Increments per interval from absolute values (integers).

    ``inc[k] = A[k] − A[k−1]``; the first point's increment is 0 (no interval ends at it).
    Their running sum from the reference gives back ``A − A[reference]``.
    """
    inc = np.zeros_like(absolute)
    inc[1:] = np.diff(absolute)
    return inc


def build(
    model: CompensationModel,
    functions: Sequence[str] | None = None,
    *,
    magnification: int = 1,
) -> list[ControlTable]:
    """The tables the control will apply: integer increments, accumulated stepwise.

    Raises
    ------
    InputError
        More than 1024 points over all axes, a rotary table not of one revolution or whose
        increments do not sum to zero, a reference position off the grid.
    """
    if not (isinstance(magnification, int) and 1 <= magnification <= 100):
        raise InputError(f"3623 magnification: {magnification!r} must be an integer 1–100")
    out, total = [], 0
    for t in select(model, _carries, functions, NAME):
        rotary = _rotary(model, t.axis)
        unit = _UNIT["linear" if t.axis in LINEAR_AXES else "rotary"] * magnification
        q = t.positions
        ref = int(np.argmin(np.abs(q - model.reference[t.axis])))
        if abs(q[ref] - model.reference[t.axis]) > 1e-9 * max(1.0, abs(q[ref])):
            raise InputError(f"{t.function}: the reference position is not a point of the table")
        fwd, rev = corrections(model, t)
        both = t.bidirectional
        period = None
        if rotary:
            per_rev = 2 * np.pi / t.pitch
            if abs(per_rev - round(per_rev)) > 1e-9:
                raise InputError(
                    f"{t.function}: 3625/3624 = {per_rev:.6g} is not an integer; choose a "
                    "pitch that divides 360°"
                )
            stop = ref + round(per_rev) + 1
            if stop > q.size:
                raise InputError(f"{t.function}: the table does not cover one revolution")
            q, fwd, rev, period = q[ref:stop], fwd[ref:stop], rev[ref:stop], 2 * np.pi
            ref = 0
        # one zero for both directions: the forward value at the reference position; the
        # reverse table's value there is 3627
        absolute = np.round((fwd - fwd[ref]) / unit)
        reverse = np.round((rev - fwd[ref]) / unit) if both else absolute
        for values, d in ((absolute, "positive"), (reverse, "negative")):
            if rotary and values[-1] != values[0]:
                raise InputError(
                    f"{t.function}: Fanuc rotary axis: the increments over one revolution "
                    f"({d} direction) sum to {values[-1] - values[0]:+.0f} units, not zero "
                    "(the error function is not periodic)"
                )
        total += q.size * (2 if both else 1)
        if total > MAX_POINTS:
            raise InputError(
                f"{t.function}: {total} compensation points over all axes; format {NAME} "
                f"accepts at most {MAX_POINTS} (numbers 0–{MAX_POINTS - 1}); choose a larger pitch"
            )
        out.append(
            ControlTable(t.function, q, absolute * unit, reverse * unit, "staircase", period, ref)
        )
    return out


def reference_notes(model: CompensationModel, tables: list[ControlTable]) -> list[str]:
    """What a Fanuc table leaves to the reference position: the correction there."""
    out = []
    for t in tables:
        src = model.table(t.function)
        ref = t.positions[t.reference_index]
        value = -model.sign * float(np.interp(ref, src.positions, src.forward))
        unit, scale = ("mm", 1.0) if t.axis in LINEAR_AXES else ("deg", _DEG)
        shown = value * (1e3 if t.axis in LINEAR_AXES else 1e3 / _DEG)
        out.append(
            f"{t.function}: the correction at the reference position {t.axis} = "
            f"{ref / scale:g} {unit} ({shown:+.4g} {'µm' if unit == 'mm' else '0.001°'}) is "
            "not in the table (a Fanuc table is zero there); apply it with the reference "
            "position shift or choose --reference"
        )
    return out


def render(tables: list[ControlTable], model: CompensationModel, *, magnification: int = 1) -> dict:
    """File name -> text: the parameters and the ``N… P…`` compensation data."""
    lines = [
        "; FANUC pitch error compensation (mtmetrology export)",
        "; values: increments per interval in detection units x 3623 (1 um, 0.001 deg)",
    ]
    data = []
    number = 0
    for t in tables:
        linear = t.axis in LINEAR_AXES
        unit = _UNIT["linear" if linear else "rotary"] * magnification
        scale = 1.0 if linear else _DEG
        absolute = np.round(t.forward / unit).astype(int)
        reverse = np.round(t.reverse / unit).astype(int)
        both = not np.array_equal(absolute, reverse)
        inc, inc_rev = increments(absolute), increments(reverse)
        if t.period is not None:  # the reference point repeats the last point's value
            inc[0], inc_rev[0] = inc[-1], inc_rev[-1]
        interval = round(
            (t.positions[1] - t.positions[0]) / _UNIT["linear" if linear else "rotary"]
        )
        lines += [
            f"; axis {t.axis}: reference position {t.positions[t.reference_index] / scale:.6f} "
            f"{'mm' if linear else 'deg'}",
            f"3620 {t.axis} {number + t.reference_index}",
            f"3621 {t.axis} {number}",
            f"3622 {t.axis} {number + t.positions.size - 1}",
            f"3623 {t.axis} {magnification}",
            f"3624 {t.axis} {interval}",
        ]
        if t.period is not None:
            lines.append(f"3625 {t.axis} {round(t.period / _UNIT['rotary'])}")
        data += [f"N{10000 + number + k} P{v:d}" for k, v in enumerate(inc)]
        number += t.positions.size
        if both:  # bidirectional (A-77810E table (a)): the negative-direction table follows
            lines += [
                f"3605#0 {t.axis} 1",
                f"3626 {t.axis} {number}",
                f"3627 {t.axis} {reverse[t.reference_index]:d}",
            ]
            data += [f"N{10000 + number + k} P{v:d}" for k, v in enumerate(inc_rev)]
            number += t.positions.size
    return {"fanuc_pitch.txt": "\n".join(lines + data) + "\n"}
