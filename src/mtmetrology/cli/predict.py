"""``mtm predict``: compensated workpiece coordinates of probing records."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from mtmetrology.cli._common import (
    MachineOption,
    ReportOption,
    command_line,
    user_errors,
    write_report,
)

if TYPE_CHECKING:
    from mtmetrology.kinematics.machine import Machine

#: ``kind`` of a Gaussian-process error-model file (``mtm gp fit``): checked before
#: anything of :mod:`mtmetrology.cmm` (scikit-learn) is imported, so that compensating with a
#: parameter set starts small and fast.
GP_KIND = "gp-error-model"


def read_error_model(path: Path, machine: Machine):
    """A parameter set or a GP model file: ``(machine, theta, gp, parameter_set)``.

    Exactly one of ``gp`` (a GP model file) and ``parameter_set`` is not None.
    """
    from mtmetrology.io.documents import load_document
    from mtmetrology.kinematics.parameter_set import ParameterSet

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


@user_errors
def predict(
    ctx: typer.Context,
    readings: Annotated[Path, typer.Argument(help="Probing records CSV: X,Y,Z,B,C[,S] ...")],
    machine: MachineOption,
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
    The CSV is for programs: every number to 6 decimals of its unit (x, y, z to 1 nm),
    not rounded to its uncertainty.
    """
    from mtmetrology._memory import release_free_memory
    from mtmetrology.io import (
        InputFileError,
        atomic_write,
        check_output,
        read_csv_table,
        write_columns,
    )
    from mtmetrology.kinematics.compensation import compensate
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.readings_table import readings_from_table, senses_from_table
    from mtmetrology.units import from_internal

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
        from mtmetrology.cmm.files import load_probes, probe_tools

        tools = probe_tools(load_probes(probes), table)
    q = readings_from_table(m, table)
    senses = senses_from_table(m, table)
    release_free_memory()  # the float casts of the columns, now copied into q
    result = compensate(
        m,
        q,
        theta,
        None if pset is None else pset.covariance,
        senses=senses,
        tool=tools,
        error_model=gp,
        with_u=with_u,
        source=str(readings),
        lines=table.lines,
    )
    xyz, u = result.points, result.u
    if report_path is not None:
        from mtmetrology.report import Report
        from mtmetrology.report.results import add_result

        nominal = compensate(m, q, senses=senses, tool=tools).points
        report = Report(
            f"Compensated coordinates: {readings.name}",
            command=command_line(ctx),
            provenance={"inputs": inputs},
        )
        add_result(report, result, nominal=nominal, machine=m)
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
