"""Shared command-line plumbing: user errors become one line on stderr and exit code 2."""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from functools import wraps

import numpy as np
import typer

from mtmetrology.io.files import InputFileError, Table
from mtmetrology.kinematics.machine import Machine
from mtmetrology.units import UnitError

USER_ERRORS = (InputFileError, ValueError, KeyError, UnitError, FileNotFoundError)


def fail(message: str) -> None:
    """Print ``error: message`` on stderr and exit with code 2."""
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(code=2)


def user_errors(func: Callable) -> Callable:
    """Turn the library's input errors into :func:`fail` (no traceback for bad input)."""

    @wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except USER_ERRORS as err:
            msg = err.args[0] if isinstance(err, KeyError) and err.args else str(err)
            fail(str(msg))

    return wrapper


def print_json(document: dict) -> None:
    sys.stdout.write(json.dumps(document, indent=2, ensure_ascii=False, allow_nan=False) + "\n")


def readings_from_table(machine: Machine, table: Table) -> np.ndarray:
    """Internal readings from a CSV with one column per axis (mm, degrees); S defaults to 0."""
    cols = {}
    for a in machine.axis_names:
        if table.has(a):
            cols[a] = table.floats(a)
        elif a != "S":
            table.floats(a)  # raises: missing column, naming the file
    return machine.readings_from_customary(cols)


def senses_from_table(machine: Machine, table: Table) -> np.ndarray | None:
    """``sense_<axis>`` columns (+1/−1) when present, else None."""
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
