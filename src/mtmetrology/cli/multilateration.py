"""``mtm multilateration simulate`` and ``mtm multilateration calibrate``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from mtmetrology.cli._common import (
    ErrorModelOption,
    KeepAPrioriOption,
    MachineOption,
    ReportOption,
    adequacy_rule,
    command_line,
    emit_result,
    user_errors,
    vector_option,
)
from mtmetrology.cli._progress import progress_bar
from mtmetrology.errors import InputError

simulate_app = typer.Typer()
calibrate_app = typer.Typer()

SPEC_HELP = "Length uncertainty U(k=2) = A + B·L, e.g. 0.2um+0.3um/m (LaserTRACER NG)."
SIMULATE_HELP = """Lengths of a sequential multilateration on a virtual machine.

STATIONS.yaml: kind multilateration-stations, version 1, stations: [{name, position_mm,
dead_path_mm}] in the workpiece frame.  The poses are a --grid NX,NY,NZ over the travel of
the linear axes, visited by every station with every reflector --tool (x,y,z mm; repeat
the option; default the machine's tool and two offsets of 80 mm sideways and 50 mm down).
Each length is ‖p(q; θ, t) − S‖ − ℓ0 + ε, ε ~ N(0, (A/2 + B/2·L)²) from --noise.
Writes LENGTHS.csv: station,<axes>,tool_x,tool_y,tool_z,length (mm).
"""

CALIBRATE_HELP = """Identify the machine's errors from multilateration lengths.

LENGTHS.csv: station,<axes>,tool_x,tool_y,tool_z,length (mm, rotary axes in degrees).
Unknowns: the error model's parameters, each station's centre and dead path.  Weights
1/u(ℓ) from --noise (default the LaserTRACER NG, U(k=2) = 0.2 µm + 0.3 µm/m); the
parameter covariance is (JᵀJ)⁻¹.  A set-up that cannot see a parameter is refused with
the unobservable combinations named (a reflector on the spindle axis only cannot see
the yaws of the axes that carry the tool: measure with laterally offset tools).
When the residuals contradict --noise or the model (chi-squared p < 0.01) the output
says so and the covariance is scaled by the variance factor s² (unless
--keep-a-priori-covariance); the residual RMS by station and by tool shows where.
-o writes MAP.json: the parameter set with covariance (stations in its provenance), for
--params of other commands.  --mc N checks the map uncertainty at 27 points of the
measured volume by N Monte Carlo re-solves.
"""


def _grid(text: str) -> list[int]:
    try:
        return [int(c) for c in text.split(",")]
    except ValueError:
        raise InputError(f"--grid needs node counts NX,NY,NZ, got {text!r}") from None


@simulate_app.command("multilateration", help=SIMULATE_HELP)
@user_errors
def simulate_multilateration(
    machine: MachineOption,
    stations: Annotated[Path, typer.Option("--stations", help="STATIONS.yaml.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="LENGTHS.csv to write.")],
    truth: Annotated[
        Path | None, typer.Option("--truth", help="TRUTH.json (zero errors if omitted).")
    ] = None,
    model: ErrorModelOption = None,
    grid: Annotated[str, typer.Option("--grid", help="Poses per linear axis NX,NY,NZ.")] = (
        "5,8,5"
    ),
    tool: Annotated[
        list[str] | None, typer.Option("--tool", help="Reflector vector x,y,z (mm), repeat.")
    ] = None,
    noise: Annotated[str, typer.Option("--noise", help=SPEC_HELP)] = "0.2um+0.3um/m",
    seed: Annotated[int | None, typer.Option("--seed", help="Random seed.")] = None,
) -> None:
    from mtmetrology.io import check_output
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.parameter_set import ParameterSet
    from mtmetrology.multilateration.files import read_stations, write_lengths
    from mtmetrology.multilateration.problem import parse_spec
    from mtmetrology.multilateration.requests import pose_grid, reflector_tools
    from mtmetrology.multilateration.workflow import simulate_lengths

    check_output(output, [stations] + ([truth] if truth else []))
    m = Machine.load(machine, model)
    theta = None
    if truth is not None:
        pset = ParameterSet.load(truth, m)
        m = pset.machine_for(m)
        theta = pset.vector_for(m)
    tools = [vector_option(t, "--tool") for t in tool or ()]
    record = simulate_lengths(
        m,
        theta,
        read_stations(stations),
        pose_grid(m, _grid(grid)),
        reflector_tools(m, tools),
        spec=parse_spec(noise),
        seed=seed,
    )
    write_lengths(output, m, record)
    typer.echo(f"wrote {len(record.lengths)} lengths to {output}", err=True)


@calibrate_app.command("multilateration", help=CALIBRATE_HELP)
@user_errors
def calibrate_multilateration_cmd(
    ctx: typer.Context,
    lengths: Annotated[Path, typer.Argument(help="LENGTHS.csv.")],
    machine: MachineOption,
    model: ErrorModelOption = None,
    noise: Annotated[str, typer.Option("--noise", help=SPEC_HELP)] = "0.2um+0.3um/m",
    mc: Annotated[
        int, typer.Option("--mc", help="Monte Carlo trials checking the map uncertainty.")
    ] = 0,
    seed: Annotated[int | None, typer.Option("--seed", help="Seed of --mc.")] = None,
    keep_a_priori: KeepAPrioriOption = False,
    json: Annotated[bool, typer.Option("--json", help="Print the JSON document.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="MAP.json.")] = None,
    report_path: ReportOption = None,
) -> None:
    from mtmetrology.formatting import format_uncertainty, format_value
    from mtmetrology.io import check_output
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.multilateration.requests import calibrate_multilateration_file
    from mtmetrology.units import from_internal

    for target in (output, report_path):
        if target is not None:
            check_output(target, [lengths])
    m = Machine.load(machine, model)
    with progress_bar("map check trials") as progress:
        result = calibrate_multilateration_file(
            lengths, m, noise=noise, mc=mc, seed=seed, adequacy=adequacy_rule(keep_a_priori),
            progress=progress,
        )  # fmt: skip
    doc = result.to_dict()
    check = result.map_check
    report = None
    if report_path is not None:
        from mtmetrology.report import Report
        from mtmetrology.report.results import add_result

        report = Report(
            f"Sequential multilateration: {lengths.name}",
            command=command_line(ctx),
            provenance={"inputs": [lengths], "seed": seed},
        )
        report.section("Stations", result.message)
        report.table(
            ["station", "x (mm)", "y (mm)", "z (mm)", "dead path (mm)", "u max (µm)"],
            [
                [s.name, *s.position, s.dead_path, float(from_internal(u.max(), "µm"))]
                for s, u in zip(result.stations, result.station_u, strict=True)
            ],
        )
        add_result(report, result.adequacy, patterns=result.residual_patterns)
        add_result(report, result.parameters)

    def summary() -> None:
        prov = doc["provenance"]
        typer.echo(f"multilateration of {m.name}: {result.n_lengths} lengths, {result.message}")
        typer.echo(f"  residual rms {prov['residual_rms_um']:.3f} µm; {result.adequacy.message}")
        worst = max(result.residual_patterns["station"], key=lambda g: g["rms_weighted"])
        typer.echo(
            "  residual rms by station: "
            + ", ".join(
                f"{g['group']} {format_uncertainty(g['rms_µm'])} µm"
                for g in prov["residual_patterns"]["station"]
            )
            + f" (largest weighted rms {worst['rms_weighted']:.2g} at {worst['group']})"
        )
        if result.setup_terms.candidates:
            typer.echo(f"  constants of the tool-side axes: {result.setup_terms.message}")
        for s, u in zip(result.stations, result.station_u, strict=True):
            # each coordinate to the decimal of the largest u of the three (GUM 7.2.6)
            u_mm = float(u[:3].max())
            pos = ", ".join(format_value(v, u_mm) for v in s.position)
            u_um = format_uncertainty(from_internal(u_mm, "µm"))
            dead = format_value(s.dead_path, float(u[3]))
            typer.echo(
                f"  station {s.name}: ({pos}) mm, largest u = {u_um} µm; dead path {dead} mm"
            )
        if check is not None:
            u_map = format_uncertainty(from_internal(check.u_guf.max(), "µm"))
            typer.echo(
                f"  map u (GUF) up to {u_map} µm; Monte Carlo ({check.trials} trials) within "
                f"{100 * check.largest_ratio_deviation:.1f} % of it"
            )

    emit_result(doc, summary, output=output, report=report, report_path=report_path, as_json=json)
