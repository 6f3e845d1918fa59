"""``mtm predict``: compensated workpiece coordinates of probing records."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from mtmetrology.cli._common import readings_from_table, senses_from_table, user_errors
from mtmetrology.cli.cmm import probe_tools, read_error_model
from mtmetrology.cmm.files import load_probes
from mtmetrology.io.files import InputFileError, read_csv_table, write_csv_table
from mtmetrology.kinematics.machine import Machine


@user_errors
def predict(
    readings: Annotated[Path, typer.Argument(help="Probing records CSV: X,Y,Z,B,C[,S] ...")],
    machine: Annotated[str, typer.Option("--machine", help="Preset name or machine YAML.")],
    params: Annotated[
        Path | None,
        typer.Option(
            "--params",
            help="Parameter set (JSON/YAML) or GP model file (mtm gp fit); zero if omitted.",
        ),
    ] = None,
    probes: Annotated[
        Path | None,
        typer.Option("--probes", help="Probe set: tool vector of each row's 'probe' column."),
    ] = None,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Output CSV (standard output if omitted).")
    ] = None,
) -> None:
    """Compensated stylus-centre coordinates x, y, z (mm) in the workpiece frame.

    Readings are stylus-centre readings (mm, degrees); input columns are copied and
    x, y, z appended. Sense-of-motion columns sense_<axis> (+1/-1) feed reversal terms.
    With --probes, each row's 'probe' column selects the stylus (tool vector).
    """
    m = Machine.load(machine)
    theta, gp = None, None
    if params is not None:
        m, theta, gp = read_error_model(params, m)
    table = read_csv_table(readings)
    tools = probe_tools(load_probes(probes), table) if probes is not None else None
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
    if gp is not None:
        xyz = gp.predict(q, m.tool if tools is None else tools)[0]
    else:
        xyz = m.forward(q, theta, senses=senses, tool=tools)
    header = [*table.header, "x", "y", "z"]
    rows = (
        [*row, *(f"{v:.6f}" for v in p)]
        for row, p in zip(table.rows, np.atleast_2d(xyz), strict=True)
    )
    if output is None:
        sys.stdout.write(",".join(header) + "\n")
        for r in rows:
            sys.stdout.write(",".join(r) + "\n")
    else:
        write_csv_table(output, header, rows)
        typer.echo(f"wrote {len(table)} rows to {output}", err=True)
