"""Shared command-line plumbing: user errors become one line on stderr and exit code 2."""

from __future__ import annotations

import json
import shlex
import sys
from collections.abc import Callable
from functools import wraps
from pathlib import Path
from typing import Annotated

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


ReportOption = Annotated[
    Path | None,
    typer.Option(
        "--report",
        help="Also write a self-contained HTML report (tables, figures, provenance) here.",
        dir_okay=False,
    ),
]


def command_line(ctx: typer.Context) -> str:
    """The running command as a user would type it, rebuilt from its parsed parameters.

    Options left at their default are omitted, so the line reruns the same command.
    (Rebuilt rather than read from ``sys.argv``, which is the test runner's under
    ``CliRunner`` and ``python -m``'s when run as a module.)
    """
    words = ctx.command_path.split()
    words[0] = "mtm"
    for param in ctx.command.params:
        value = ctx.params.get(param.name)
        if value is None or value == param.get_default(ctx) or param.expose_value is False:
            continue
        if param.param_type_name == "argument":
            words += [str(v) for v in value] if isinstance(value, list | tuple) else [str(value)]
        elif getattr(param, "is_flag", False):
            flag = param.opts[0] if value else (param.secondary_opts or [None])[0]
            words += [flag] if flag else []
        else:
            values = value if isinstance(value, list | tuple) else [value]
            for v in values:
                words += [param.opts[0], str(getattr(v, "value", v))]
    return shlex.join(words)


def write_report(report, path: Path) -> None:
    """Write ``report`` atomically to ``path`` and say so on stderr (stdout stays data)."""
    try:
        report.write(path)
    except OSError as exc:
        fail(f"{path}: cannot write the report ({exc.strerror or exc})")
    typer.echo(f"report written to {path}", err=True)
