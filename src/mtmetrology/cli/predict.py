"""``mtm predict``: compensated workpiece coordinates of probing records."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from mtmetrology._memory import release_free_memory
from mtmetrology.cli._common import (
    ReportOption,
    command_line,
    readings_from_table,
    senses_from_table,
    user_errors,
    write_report,
)
from mtmetrology.io import (
    InputFileError,
    atomic_write,
    check_output,
    read_csv_table,
    write_columns,
)
from mtmetrology.io.documents import load_document
from mtmetrology.kinematics.compensation import compensated_points
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.units import from_internal


def add_compensation(report, machine: Machine, xyz: np.ndarray, nominal: np.ndarray) -> None:
    """The correction each point receives from the error model: statistics and vectors."""
    from mtmetrology.report import figures

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


#: ``kind`` of a Gaussian-process error-model file (``mtm gp fit``): checked before
#: anything of :mod:`mtmetrology.cmm` (scikit-learn) is imported, so that compensating with a
#: parameter set starts small and fast.
GP_KIND = "gp-error-model"


def read_error_model(path: Path, machine: Machine):
    """A parameter set or a GP model file: ``(machine, theta, gp, parameter_set)``.

    Exactly one of ``gp`` (a GP model file) and ``parameter_set`` is not None.
    """
    doc = load_document(path, "error model")
    if isinstance(doc, dict) and doc.get("kind") == GP_KIND:
        from mtmetrology.cmm.gp import GPErrorModel

        gp = GPErrorModel.from_document(doc, machine, str(path))
        return gp.machine, None, gp, None
    pset = ParameterSet.from_document(doc, machine, str(path))
    m = pset.machine_for(machine)
    return m, pset.vector_for(m), None, pset


#: Standard uncertainty columns of ``--u``, µm.
U_COLUMNS = ("u_x_um", "u_y_um", "u_z_um")

#: Rows evaluated at once: bounds the memory of the kinematic chain on large records.
CHUNK_ROWS = 1 << 16


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
    with_u: Annotated[
        bool,
        typer.Option(
            "--u",
            help="Append u_x_um, u_y_um, u_z_um: the standard uncertainty of each coordinate "
            "from the parameter covariance (or the GP's posterior).",
        ),
    ] = False,
    report_path: ReportOption = None,
) -> None:
    """Compensated stylus-centre coordinates x, y, z (mm) in the workpiece frame.

    Readings are stylus-centre readings (mm, degrees); input columns are copied and
    x, y, z appended. Sense-of-motion columns sense_<axis> (+1/-1) feed reversal terms.
    With --probes, each row's 'probe' column selects the stylus (tool vector). A tool
    vector identified by the calibration (tool_mm) replaces the machine's nominal one.
    With --u, u_x_um, u_y_um, u_z_um (µm) follow: √diag(G U_θ Gᵀ), G = ∂f/∂δ, the
    compensation with the estimate δ̂ of covariance U_θ (readings taken as exact).
    """
    inputs = [readings, *(p for p in (params, probes) if p is not None)]
    if Path(machine).suffix.lower() in (".yaml", ".yml", ".json"):
        inputs.append(Path(machine))
    if output is not None:
        check_output(output, inputs)
    m = Machine.load(machine)
    theta, gp, pset = None, None, None
    if params is not None:
        m, theta, gp, pset = read_error_model(params, m)
    if with_u and (pset is None or pset.covariance is None) and gp is None:
        raise InputFileError(
            f"--u needs a parameter set with a covariance (--params), got "
            f"{'none' if params is None else str(params) + ' without one'}"
        )
    table = read_csv_table(readings)
    release_free_memory()  # the reader's scratch (file bytes, parse buffers) before compute
    added = ["x", "y", "z", *(U_COLUMNS if with_u else ())]
    clash = sorted(set(table.header) & set(added))
    if clash:
        raise InputFileError(
            f"{readings}: column(s) {', '.join(clash)} already present; predict appends "
            f"{', '.join(added)}"
        )
    tools = None
    if probes is None and table.has("probe"):
        raise InputFileError(
            f"{readings}: column 'probe' selects a stylus per row; give the probe set with "
            "--probes (or remove the column to use the machine's tool)"
        )
    if probes is not None:
        from mtmetrology.cli.cmm import probe_tools
        from mtmetrology.cmm.files import load_probes

        tools = probe_tools(load_probes(probes), table)
    q = readings_from_table(m, table)
    senses = senses_from_table(m, table)
    release_free_memory()  # the float casts of the columns, now copied into q
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
    u = np.empty((len(table), 3)) if with_u else None
    for start in range(0, len(table), CHUNK_ROWS):
        rows = slice(start, start + CHUNK_ROWS)
        tool = m.tool if tools is None else tools[rows]
        s_rows = None if senses is None else senses[rows]
        if gp is not None:
            xyz[rows], u_gp = gp.predict(q[rows], tool)
            if u is not None:
                u[rows] = u_gp
        elif u is not None:
            xyz[rows], u[rows] = compensated_points(
                m, q[rows], theta, pset.covariance, senses=s_rows, tool=tool
            )
        else:
            xyz[rows] = m.forward(q[rows], theta, senses=s_rows, tool=tool)
    bad = ~np.isfinite(xyz).all(axis=1)
    if bad.any():
        raise InputFileError(
            f"{readings}, line {table.lines[np.argmax(bad)]}: the compensated position is not "
            "finite; check the readings and the parameter set"
        )
    if report_path is not None:
        from mtmetrology.report import Report
        from mtmetrology.report.results import add_result

        nominal = m.forward(q, None, senses=senses, tool=m.tool if tools is None else tools)
        report = Report(
            f"Compensated coordinates: {readings.name}",
            command=command_line(ctx),
            provenance={"inputs": inputs},
        )
        add_compensation(report, m, xyz, np.atleast_2d(nominal))
        if pset is not None:
            add_result(report, pset)
        write_report(report, report_path)
    # The readings (n, axes) are done with: let them go before the output is formatted,
    # so that they and the writer's chunks are never resident together.
    del q, senses, tools
    columns = {c: table.text.column(c) for c in table.header}
    columns.update({c: xyz[:, k] for k, c in enumerate("xyz")})
    if u is not None:
        columns.update({c: from_internal(u[:, k], "µm") for k, c in enumerate(U_COLUMNS)})
    plain = () if table.quoted else table.header
    if output is None:
        write_columns(sys.stdout.buffer, columns, decimals=6, plain=plain)
        sys.stdout.flush()
        return
    with atomic_write(output, "wb") as fh:
        write_columns(fh, columns, decimals=6, plain=plain)
    typer.echo(f"wrote {len(table)} rows to {output}", err=True)
