"""``mtm simulate multilateration`` and ``mtm calibrate multilateration``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from mtmetrology.cli._common import (
    ReportOption,
    command_line,
    print_json,
    user_errors,
    write_report,
)
from mtmetrology.errors import InputError
from mtmetrology.io import check_output
from mtmetrology.io.files import write_json
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.multilateration.files import read_lengths, read_stations, write_lengths
from mtmetrology.multilateration.problem import parse_spec
from mtmetrology.multilateration.workflow import (
    calibrate_multilateration,
    map_monte_carlo,
    simulate_lengths,
)
from mtmetrology.report.format import format_uncertainty
from mtmetrology.units import from_internal

simulate_app = typer.Typer()
calibrate_app = typer.Typer()

SPEC_HELP = "Length uncertainty U(k=2) = A + B·L, e.g. 0.2um+0.3um/m (LaserTRACER NG)."
#: Reflector offsets from the machine's tool when none is given: on the spindle axis and
#: two lateral ones, so that the yaws of the tool-side axes are observable.
DEFAULT_TOOL_OFFSETS = ((0.0, 0.0, 0.0), (80.0, 0.0, -50.0), (0.0, 80.0, -50.0))

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
-o writes MAP.json: the parameter set with covariance (stations in its provenance), for
--params of other commands.  --mc N checks the map uncertainty at 27 points of the
measured volume by N Monte Carlo re-solves.
"""


def _vector(text: str, option: str) -> tuple[float, float, float]:
    parts = [p for p in text.split(",") if p.strip()]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 3 or not all(np.isfinite(values)):
        raise InputError(f"{option} needs three numbers x,y,z in mm, got {text!r}")
    return values


def _grid(machine: Machine, text: str) -> np.ndarray:
    try:
        counts = [int(c) for c in text.split(",")]
    except ValueError:
        counts = []
    linear = [a for a in machine.axis_names if machine.axes[a].linear]
    if len(counts) != len(linear) or min(counts) < 2:
        raise InputError(
            f"--grid needs {len(linear)} node counts >= 2 (axes {''.join(linear)}), got {text!r}"
        )
    axes = []
    for a, n in zip(linear, counts, strict=True):
        travel = machine.axes[a].travel
        if travel is None:
            raise InputError(f"--grid: axis {a} of {machine.name} has no travel_mm")
        axes.append(np.linspace(*travel, n))
    nodes = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, len(linear))
    q = np.zeros((len(nodes), machine.n_axes))
    q[:, [machine.axis_names.index(a) for a in linear]] = nodes
    return q


@simulate_app.command("multilateration", help=SIMULATE_HELP)
@user_errors
def simulate_multilateration(
    machine: Annotated[str, typer.Option("--machine", help="Preset name or machine YAML.")],
    stations: Annotated[Path, typer.Option("--stations", help="STATIONS.yaml.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="LENGTHS.csv to write.")],
    truth: Annotated[
        Path | None, typer.Option("--truth", help="TRUTH.json (zero errors if omitted).")
    ] = None,
    model: Annotated[str | None, typer.Option("--model", help="Error model.")] = None,
    grid: Annotated[str, typer.Option("--grid", help="Poses per linear axis NX,NY,NZ.")] = (
        "5,8,5"
    ),
    tool: Annotated[
        list[str] | None, typer.Option("--tool", help="Reflector vector x,y,z (mm), repeat.")
    ] = None,
    noise: Annotated[str, typer.Option("--noise", help=SPEC_HELP)] = "0.2um+0.3um/m",
    seed: Annotated[int | None, typer.Option("--seed", help="Random seed.")] = None,
) -> None:
    check_output(output, [stations] + ([truth] if truth else []))
    m = Machine.load(machine, model)
    theta = None
    if truth is not None:
        pset = ParameterSet.load(truth, m)
        m = pset.machine_for(m)
        theta = pset.vector_for(m)
    if tool:
        tools = np.array([_vector(t, "--tool") for t in tool])
    else:
        tools = m.tool + np.array(DEFAULT_TOOL_OFFSETS)
    record = simulate_lengths(
        m,
        theta,
        read_stations(stations),
        _grid(m, grid),
        tools,
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
    machine: Annotated[str, typer.Option("--machine", help="Preset name or machine YAML.")],
    model: Annotated[str | None, typer.Option("--model", help="Error model.")] = None,
    noise: Annotated[str, typer.Option("--noise", help=SPEC_HELP)] = "0.2um+0.3um/m",
    mc: Annotated[
        int, typer.Option("--mc", help="Monte Carlo trials checking the map uncertainty.")
    ] = 0,
    seed: Annotated[int | None, typer.Option("--seed", help="Seed of --mc.")] = None,
    json: Annotated[bool, typer.Option("--json", help="Print the JSON document.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="MAP.json.")] = None,
    report_path: ReportOption = None,
) -> None:
    for target in (output, report_path):
        if target is not None:
            check_output(target, [lengths])
    if mc < 0:
        raise InputError(f"--mc must be >= 0 trials, got {mc}")
    m = Machine.load(machine, model)
    record = read_lengths(lengths, m)
    result = calibrate_multilateration(
        m, record, spec=parse_spec(noise), provenance={"lengths": str(lengths)}
    )
    doc = result.to_dict()
    check = None
    if mc:
        pos = m.forward(record.readings)
        axes = [np.linspace(pos[:, k].min(), pos[:, k].max(), 3) for k in range(3)]
        points = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
        check = map_monte_carlo(m, record, result, points, trials=mc, seed=seed)
        doc["provenance"]["map_monte_carlo"] = check.to_dict()
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
        add_result(report, result.parameters)
    if output is not None:
        write_json(output, doc)
    if report is not None:
        write_report(report, report_path)
    if json:
        print_json(doc)
        return
    prov = doc["provenance"]
    factor = result.variance_factor
    typer.echo(f"multilateration of {m.name}: {result.n_lengths} lengths, {result.message}")
    typer.echo(
        f"  residual rms {prov['residual_rms_um']:.3f} µm, variance factor "
        f"{'-' if factor is None else f'{factor:.3f}'}"
    )
    for s, u in zip(result.stations, result.station_u, strict=True):
        pos = ", ".join(f"{v:.4f}" for v in s.position)
        u_um = format_uncertainty(from_internal(u[:3].max(), "µm"))
        typer.echo(f"  station {s.name}: ({pos}) mm ± {u_um} µm, dead path {s.dead_path:.4f} mm")
    if check is not None:
        typer.echo(
            f"  map u (GUF) up to {format_uncertainty(from_internal(check.u_guf.max(), 'µm'))} µm;"
            f" Monte Carlo ({check.trials} trials) within "
            f"{100 * check.largest_ratio_deviation:.1f} % of it"
        )
