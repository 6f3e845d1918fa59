"""``mtm machine``: presets, machine files and identifiability."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table as RichTable

from mtmetrology.cli._common import (
    ReportOption,
    command_line,
    emit_result,
    user_errors,
)
from mtmetrology.errors import EXIT_INPUT, InputError, RankDeficientError

app = typer.Typer(
    help="Machine definitions: list, show, export, check, identifiability.",
    no_args_is_help=True,
)

MachineArg = Annotated[str, typer.Argument(help="Preset name or machine YAML file.")]
ModelOpt = Annotated[
    str | None, typer.Option("--model", help="Named error model of the definition.")
]


@app.command("list")
def list_command() -> None:
    """List the machine presets shipped with mtmetrology."""
    from mtmetrology.kinematics.preset_registry import preset_summaries

    console = Console()
    table = RichTable(title="machine presets")
    for col in ("name", "topology", "error models", "description"):
        table.add_column(col)
    for preset in preset_summaries():
        desc = preset.description.split(",")[0].split(":")[0]
        table.add_row(preset.name, preset.topology, ", ".join(preset.error_models), desc)
    console.print(table)


def _direction_label(v) -> str:
    """``+X``/``-Z`` for axis-aligned directions, else the vector."""
    for k, letter in enumerate("XYZ"):
        if abs(abs(v[k]) - 1.0) < 1e-12:
            return ("+" if v[k] > 0 else "-") + letter
    return "(" + ", ".join(f"{c:.6g}" for c in v) + ")"


@app.command("show")
@user_errors
def show(
    machine: MachineArg,
    model: ModelOpt = None,
    catalogue: Annotated[
        bool,
        typer.Option(
            "--catalogue", help="List every candidate error parameter of the topology instead."
        ),
    ] = False,
    degree: Annotated[int, typer.Option(help="Highest error-motion degree in the catalogue.")] = 3,
    json: Annotated[bool, typer.Option("--json", help="Print a JSON document.")] = False,
) -> None:
    """Show a machine: axes, and the parameters of its error model with units."""
    from mtmetrology.kinematics.conventions import machine_description
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.parameters import MAX_DEGREE

    if not 0 <= degree <= MAX_DEGREE:
        raise InputError(f"--degree must be 0 to {MAX_DEGREE}, got {degree}")
    m = Machine.load(machine, model)
    if catalogue:
        m = m.with_parameters([p.name for p in m.catalogue(degree)])
    doc = machine_description(m)

    def summary() -> None:
        console = Console()
        console.print(f"[bold]{m.name}[/bold]  topology {m.topology.string}  model {m.model_name}")
        at = RichTable(title="axes")
        for col in ("axis", "type", "branch", "direction", "sign", "travel", "resolution", "basis"):
            at.add_column(col)
        for a in doc["axes"]:
            travel = "" if a["travel"] is None else f"{a['travel'][0]:g} .. {a['travel'][1]:g}"
            res = "" if a["resolution"] is None else f"{a['resolution']:g}"
            at.add_row(
                a["axis"],
                a["type"],
                a["branch"],
                _direction_label(a["direction"]),
                f"{a['sign']:+d}",
                f"{travel} {a['unit']}",
                f"{res} {a['unit']}",
                a["basis"],
            )
        console.print(at)
        title = "catalogue" if catalogue else f"error model {m.model_name}"
        pt = RichTable(title=f"{title}: {m.n_params} parameters", show_lines=True)
        for col in ("parameter", "unit", "a positive value", "referred to"):
            pt.add_column(col, overflow="fold")
        for p in doc["parameters"]:
            pt.add_row(p["name"], p["unit"], p["positive"], p["reference"])
        console.print(pt)
        console.print(
            "Error motions are deviations of the tool relative to the workpiece (ISO 230-1, "
            "ISO 841), whichever component moves; location errors place the axis average lines "
            f"in the machine frame (right-hand rule). Stylus centre at zero readings: "
            f"{tuple(doc['stylus_at_zero_mm'])} mm."
        )

    emit_result(doc, summary, output=None, report=None, report_path=None, as_json=json)


@app.command("export")
@user_errors
def export(
    preset: Annotated[str, typer.Argument(help="Preset name (mtm machine list).")],
    output: Annotated[
        Path | None,
        typer.Option("-o", "--output", help="Machine YAML to write (standard output if omitted)."),
    ] = None,
) -> None:
    """Write a preset as a machine file, to edit (travels, offsets, models) and give to
    --machine FILE; read unchanged, it is the preset."""
    from mtmetrology.kinematics.preset_registry import preset_text

    text = preset_text(preset)
    if output is None:
        typer.echo(text, nl=False)
        return
    from mtmetrology.io.files import atomic_write, check_output

    check_output(output)
    with atomic_write(output, "w") as fh:
        fh.write(text)
    typer.echo(f"wrote {output}", err=True)


@app.command("check")
@user_errors
def check(machine_file: Annotated[Path, typer.Argument(help="Machine YAML file.")]) -> None:
    """Validate a machine file: schema, topology, every error model."""
    from mtmetrology.kinematics.machine import Machine

    first = Machine.load(machine_file)
    names = list(first.spec.error_models) if first.spec else []
    console = Console()
    console.print(f"{machine_file}: machine {first.name!r}, topology {first.topology.string}")
    for n in names:
        m = Machine.load(machine_file, n)
        console.print(f"  model {n!r}: {m.n_params} parameters, OK")
    if not names:
        console.print("  no error model defined (nominal kinematics only)")
    console.print("valid")


def _identifiability_report(result, command, inputs):
    import mtmetrology.samba.report  # noqa: F401  (registers the SAMBA renderers)
    from mtmetrology.report import Report
    from mtmetrology.report.results import add_result

    report = Report(
        "Identifiability of a probing set-up",
        command=command,
        provenance={"inputs": [p for p in inputs if p is not None]},
    )
    return add_result(report, result)


@app.command("identifiability")
@user_errors
def identifiability(
    ctx: typer.Context,
    machine: MachineArg,
    poses: Annotated[
        Path, typer.Argument(help="Ball-centre indications CSV: ball,X,Y,Z,B,C[,S][,tool].")
    ],
    model: ModelOpt = None,
    artefact: Annotated[Path | None, typer.Option(help="SAMBA artefact YAML (scale bar).")] = None,
    add: Annotated[
        list[str] | None, typer.Option("--add", help="Extra parameter to test (repeatable).")
    ] = None,
    estimate_tool: Annotated[
        bool, typer.Option(help="Tool offset among the unknowns (needs S indexing).")
    ] = True,
    sigma_um: Annotated[
        float,
        typer.Option(
            "--sigma-um",
            help="Standard uncertainty of one indication coordinate, µm (row weights; the "
            "scale bar keeps its u from the artefact file).",
        ),
    ] = 1.0,
    allow_deficient: Annotated[
        bool,
        typer.Option(
            "--allow-deficient",
            help="Report a rank-deficient set-up and exit 0 instead of refusing it.",
        ),
    ] = False,
    json: Annotated[bool, typer.Option("--json", help="Print a JSON document.")] = False,
    report_path: ReportOption = None,
) -> None:
    """Rank, conditioning and unidentifiable combinations of a probing set-up.

    The Jacobian is evaluated at the nominal point (zero errors); ball centres are
    nuisance unknowns, and so is the tool offset unless --no-estimate-tool (one per stylus
    of a tool column, their vectors from the artefact's tools). A
    rank-deficient set-up exits with code 2 after naming the confounded parameters
    (exit 0 with --allow-deficient).
    """
    # here, not at the top: ``mtm machine list`` needs neither the identification nor
    # the CSV reader (pyarrow)
    from mtmetrology.samba.identifiability import setup_identifiability

    result = setup_identifiability(
        machine,
        poses,
        model=model,
        artefact=artefact,
        add=add,
        estimate_tool=estimate_tool,
        sigma_um=sigma_um,
    )
    rep = result.diagnosis
    deficient = not rep.full_rank and not allow_deficient
    report = None
    if report_path is not None:
        report = _identifiability_report(result, command_line(ctx), [poses, artefact])

    def summary() -> None:
        console = Console()
        if not rep.full_rank:
            console.print(f"[bold red]rank deficient[/bold red]: {rep.message}")
        console.print(
            f"{result.machine}: {result.n_params} parameters, {result.n_balls} balls, "
            f"{result.n_indications} indications, {result.n_scale_bars} scale bar(s), "
            f"tool {'estimated' if estimate_tool else 'known'}, indication σ = {sigma_um:g} µm"
        )
        console.print(f"unknowns {rep.n_unknowns}, rank {rep.rank}")
        if rep.full_rank:
            console.print(
                f"condition number {rep.condition_scaled:.4g} (columns scaled to unit norm), "
                f"{rep.condition_raw:.4g} (raw: mm, rad, internal units)"
            )
            console.print(
                "observability " + ", ".join(f"{k} {v:.4g}" for k, v in rep.observability.items())
            )
            s = rep.singular_values
            console.print(
                f"singular values (columns scaled): largest {s[0]:.4g}, smallest {s[-1]:.4g}; "
                "--json lists them all"
            )
        else:
            console.print("unidentifiable combinations:")
            for d in rep.null_directions:
                console.print(f"  {d}    ({d.combination()})")
            if deficient:
                raise RankDeficientError(
                    f"rank {rep.rank} of {rep.n_unknowns}: {rep.message.split(': ', 1)[-1]}; "
                    "add balls, indexations or spindle indexing that separate them "
                    "(--allow-deficient reports without failing)",
                    confounded=rep.confounded(),
                )

    emit_result(
        result.to_dict(),
        summary,
        output=None,
        report=report,
        report_path=report_path,
        as_json=json,
    )
    if json and deficient:
        raise typer.Exit(code=EXIT_INPUT)
