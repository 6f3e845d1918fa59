"""``mtm predict``: compensated workpiece coordinates of probing records."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from mtmetrology.cli._common import (
    ReportOption,
    command_line,
    readings_from_table,
    senses_from_table,
    user_errors,
    write_report,
)
from mtmetrology.cli.cmm import probe_tools, read_error_model
from mtmetrology.cmm.files import load_probes
from mtmetrology.io.files import InputFileError, read_csv_table, write_csv_table
from mtmetrology.kinematics.machine import Machine


def add_compensation(report, machine: Machine, xyz: np.ndarray, nominal: np.ndarray) -> None:
    """The correction each point receives from the error model: statistics and vectors."""
    from mtmetrology.report import figures
    from mtmetrology.units import from_internal

    correction = from_internal(xyz - nominal, "µm")  # (n, 3)
    size = np.linalg.norm(correction, axis=1)
    report.section(
        "Compensation",
        f"{machine.name}, model {machine.model_name or 'custom'}: x, y, z are the stylus-centre "
        "positions in the workpiece frame with the parameter set's errors, the correction is "
        "their difference from the nominal (error-free) kinematics.",
    )
    report.table(
        ["quantity", "value", "unit"],
        [
            ["points", len(size), ""],
            ["largest correction", f"{size.max():.4g}", "µm"],
            ["rms correction", f"{np.sqrt(np.mean(size**2)):.4g}", "µm"],
        ],
    )
    report.figure(
        figures.residual_vectors(xyz, correction, title="Corrections"),
        caption="Correction of each point (compensated minus nominal position).",
    )


@user_errors
def predict(
    ctx: typer.Context,
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
    report_path: ReportOption = None,
) -> None:
    """Compensated stylus-centre coordinates x, y, z (mm) in the workpiece frame.

    Readings are stylus-centre readings (mm, degrees); input columns are copied and
    x, y, z appended. Sense-of-motion columns sense_<axis> (+1/-1) feed reversal terms.
    With --probes, each row's 'probe' column selects the stylus (tool vector).
    """
    m = Machine.load(machine)
    theta, gp, pset = None, None, None
    if params is not None:
        m, theta, gp, pset = read_error_model(params, m)
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
    if report_path is not None:
        from mtmetrology.report import Report
        from mtmetrology.report.results import add_result

        nominal = m.forward(q, None, senses=senses, tool=tools)
        report = Report(
            f"Compensated coordinates: {readings.name}",
            command=command_line(ctx),
            provenance={"inputs": [readings, *([] if params is None else [params])]},
        )
        add_compensation(report, m, np.atleast_2d(xyz), np.atleast_2d(nominal))
        if pset is not None:
            add_result(report, pset)
        write_report(report, report_path)
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
