"""``mtm predict``: compensated workpiece coordinates of probing records."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from mtmetrology.cli._common import readings_from_table, senses_from_table, user_errors
from mtmetrology.io import (
    InputFileError,
    atomic_write,
    check_output,
    read_csv_table,
    write_columns,
)
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

#: Rows evaluated at once: bounds the memory of the kinematic chain on large records.
CHUNK_ROWS = 1 << 16


@user_errors
def predict(
    readings: Annotated[Path, typer.Argument(help="Probing records CSV: X,Y,Z,B,C[,S] ...")],
    machine: Annotated[str, typer.Option("--machine", help="Preset name or machine YAML.")],
    params: Annotated[
        Path | None, typer.Option("--params", help="Parameter set (JSON/YAML); zero if omitted.")
    ] = None,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Output CSV (standard output if omitted).")
    ] = None,
) -> None:
    """Compensated stylus-centre coordinates x, y, z (mm) in the workpiece frame.

    Readings are stylus-centre readings (mm, degrees); input columns are copied and
    x, y, z appended. Sense-of-motion columns sense_<axis> (+1/-1) feed reversal terms.
    """
    inputs = [readings, *([params] if params is not None else [])]
    if Path(machine).suffix.lower() in (".yaml", ".yml", ".json"):
        inputs.append(Path(machine))
    if output is not None:
        check_output(output, inputs)
    m = Machine.load(machine)
    if params is not None:
        pset = ParameterSet.load(params, m)
        m = pset.machine_for(m)
        theta = pset.vector_for(m)
    else:
        theta = None
    table = read_csv_table(readings)
    clash = sorted(set(table.header) & {"x", "y", "z"})
    if clash:
        raise InputFileError(
            f"{readings}: column(s) {', '.join(clash)} already present; predict appends x, y, z"
        )
    q = readings_from_table(m, table)
    senses = senses_from_table(m, table)
    reversal = [p.name for p in m.parameters if p.kind == "reversal"]
    if reversal and senses is None:
        columns = ", ".join(
            sorted({f"sense_{p.axis}" for p in m.parameters if p.kind == "reversal"})
        )
        raise InputFileError(
            f"{readings}: the parameter set has reversal terms ({', '.join(reversal)}); "
            f"add the sense-of-motion column(s) {columns} (+1 or -1)"
        )
    xyz = np.empty((len(table), 3))
    for start in range(0, len(table), CHUNK_ROWS):
        rows = slice(start, start + CHUNK_ROWS)
        xyz[rows] = m.forward(q[rows], theta, senses=None if senses is None else senses[rows])
    bad = ~np.isfinite(xyz).all(axis=1)
    if bad.any():
        raise InputFileError(
            f"{readings}, line {table.lines[np.argmax(bad)]}: the compensated position is not "
            "finite; check the readings and the parameter set"
        )
    columns = {c: table.text.column(c) for c in table.header}
    columns.update({c: xyz[:, k] for k, c in enumerate("xyz")})
    plain = () if table.quoted else table.header
    if output is None:
        write_columns(sys.stdout.buffer, columns, decimals=6, plain=plain)
        sys.stdout.flush()
        return
    with atomic_write(output, "wb") as fh:
        write_columns(fh, columns, decimals=6, plain=plain)
    typer.echo(f"wrote {len(table)} rows to {output}", err=True)
