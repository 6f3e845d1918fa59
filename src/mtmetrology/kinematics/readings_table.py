"""Axis readings and traverse senses read from a table with one column per axis.

The one reader of probed or commanded readings (mm for a linear axis, degrees for a
rotary one) used by the workflows and the command line; the readings come back in the
internal units (mm, rad) in ``machine.axis_names`` order.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.io.files import InputFileError
from mtmetrology.io.tables import Table
from mtmetrology.kinematics.machine import Machine
from mtmetrology.units import from_internal

__all__ = ["readings_from_table", "senses_from_table"]


def readings_from_table(machine: Machine, table: Table) -> np.ndarray:
    """Internal readings from a table with one column per axis (mm, degrees); S defaults to 0.

    Parameters
    ----------
    machine : Machine
        Gives the axes, their kinds and their travels.
    table : Table
        One row per pose, one column per axis name.

    Returns
    -------
    (n, n_axes) ndarray
        Readings in mm and rad.

    Raises
    ------
    InputFileError
        A missing column or a cell that is not a number; a reading outside the travel of
        its axis (machine file ``travel_mm``/``travel_deg``) is refused with its line, its
        column and the travel: no measurement was taken there.
    """
    readings = np.zeros((len(table), machine.n_axes))  # a missing S stays 0
    for k, a in enumerate(machine.axis_names):
        if a == "S" and not table.has(a):
            continue
        axis = machine.axes[a]
        unit = "mm" if axis.linear else "deg"
        values = table.floats(a, unit=unit)
        if axis.travel is not None:
            low, high = (float(from_internal(t, unit)) for t in axis.travel)
            slack = 1e-9 * max(abs(low), abs(high), 1.0)  # the round trip through rad
            out = (values < low - slack) | (values > high + slack)
            if out.any():
                i = int(np.argmax(out))
                raise InputFileError(
                    f"{table.path}, line {table.lines[i]}: {a} = {values[i]:g} {unit} "
                    f"lies outside the travel of {machine.name} [{low:g}, {high:g}] {unit}; "
                    "check the readings or the machine file"
                )
        readings[:, k] = values
    # In place, one column at a time: records of millions of rows are not copied thrice.
    readings *= machine.readings_from_customary(np.ones(machine.n_axes))
    return readings


def senses_from_table(machine: Machine, table: Table) -> np.ndarray | None:
    """``sense_<axis>`` columns (+1/−1, the traverse direction of each axis) when present.

    Returns
    -------
    (n, n_axes) ndarray or None
        +1 where a column is absent; None when the table has no ``sense_`` column.
    """
    names = [f"sense_{a}" for a in machine.axis_names]
    if not any(table.has(n) for n in names):
        return None
    out = np.ones((len(table), machine.n_axes))
    for k, n in enumerate(names):
        if table.has(n):
            v = table.floats(n)
            bad = np.flatnonzero(~np.isin(v, (-1.0, 1.0)))
            if bad.size:
                raise InputFileError(
                    f"{table.path}, line {table.lines[bad[0]]}: column {n!r} must be +1 or -1"
                )
            out[:, k] = v
    return out
