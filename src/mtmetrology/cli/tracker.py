"""``mtm tracker simulate``, ``mtm tracker calibrate``, ``mtm tracker verify``, ``mtm tracker
plan``: laser-tracker volumetric verification (Aguado et al. (2019)).

Each command parses its options, calls one library function of :mod:`mtmetrology.tracker`,
prints a summary (or the JSON with ``--json``) and writes its outputs; the library is
imported inside the commands so that other commands start without it.
"""

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
    parse_tools,
    user_errors,
)
from mtmetrology.cli._progress import progress_bar
from mtmetrology.errors import InputError

simulate_app = typer.Typer()
calibrate_app = typer.Typer()
verify_app = typer.Typer()
design_app = typer.Typer()

MESH_HELP = "Mesh start:stop:step for X, Y, Z in mm, e.g. 800:1200:100,100:500:100,200:400:100."
POSE_HELP = (
    "POSE.yaml: kind tracker-pose, version 1, D_mm, L_mm, H_mm (along machine x, y, z), "
    "alpha_deg, beta_deg, delta_deg (R = Rx Ry Rz, eq. 22). The paper's Study 2 pose if omitted."
)
TOOLS_HELP = (
    "TOOLS.yaml: kind tracker-tools, version 1, tools_mm: [[x, y, z], ...]; one tool "
    "(0, 0, -100) if omitted."
)
NoiseOption = Annotated[
    float, typer.Option("--angle-urad", help="Angular noise level of the tracker, µrad.")
]
RangeNoiseOption = Annotated[
    str | None,
    typer.Option(
        "--range-noise",
        help="Range noise A,B: u_r = A + B·r with A in µm and B in µm/m (standard "
        "uncertainties); 4,0.8 (the source's tracker) if omitted.",
    ),
]
SpreadOption = Annotated[
    float | None,
    typer.Option(
        "--angle-spread",
        help="Standard deviation of the angular level itself, µrad (the level is drawn once "
        "per verification); 3 if omitted.",
    ),
]
SmrOption = Annotated[
    float | None,
    typer.Option("--smr", help="Isotropic SMR-centring standard uncertainty, µm; 0 if omitted."),
]
KNOWN_POSE_HELP = (
    "POSE.yaml: a known tracker pose (kind tracker-pose, the fields of simulate's --pose, "
    "in the machine frame of the model: see the tracker docs). Fixed; a prior when it also "
    "gives u_D_mm, u_L_mm, u_H_mm, u_alpha_deg, u_beta_deg, u_delta_deg (standard "
    "uncertainties). Identified with the errors if omitted."
)
TOOL_ID_HELP = (
    "ID=x,y,z: the offset (mm) of tool ID for the rows of MEASUREMENTS.csv whose 'tool' "
    "column reads ID (in place of their tool_x, tool_y, tool_z). Repeatable."
)


CONDITIONS_HELP = (
    "CONDITIONS.yaml: kind tracker-conditions, version 1, any of sensor_temperatures_C "
    "(3 x 2, per axis X, Y, Z at the lower and upper travel end), u_sensor_K, cte_per_K, "
    "u_cte_per_K, reversal_mm, repeatability_mm, geometric_random, geometric_distribution "
    "(normal or beta); 20 °C, steel, none otherwise."
)


@simulate_app.command("tracker")
@user_errors
def simulate_tracker(
    machine: MachineOption,
    mesh: Annotated[str, typer.Option("--mesh", help=MESH_HELP)],
    output: Annotated[Path, typer.Option("-o", "--output", help="MEASUREMENTS.csv to write.")],
    truth: Annotated[
        Path | None, typer.Option("--truth", help="TRUTH.json parameter set (zero if omitted).")
    ] = None,
    pose: Annotated[Path | None, typer.Option("--pose", help=POSE_HELP)] = None,
    tools: Annotated[Path | None, typer.Option("--tools", help=TOOLS_HELP)] = None,
    angle_urad: NoiseOption = 20.0,
    range_noise: RangeNoiseOption = None,
    angle_spread: SpreadOption = None,
    smr: SmrOption = None,
    conditions: Annotated[Path | None, typer.Option("--conditions", help=CONDITIONS_HELP)] = None,
    seed: Annotated[int | None, typer.Option("--seed", help="Random seed.")] = None,
) -> None:
    """Tracker readings (range, azimuth, elevation) and axis temperatures of a virtual
    verification of a machine with known errors."""
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.tracker import files, parse_mesh, simulate

    m = Machine.load(machine)
    theta = files.true_errors(m, truth)
    meas = simulate(
        m,
        theta,
        files.load_pose(pose),
        parse_mesh(mesh, m),
        files.load_tools(tools),
        noise=files.noise(angle_urad, range_noise, angle_spread, smr),
        conditions=files.load_conditions(conditions),
        seed=seed,
    )
    meas.write(output)
    typer.echo(f"wrote {len(meas)} tracker readings to {output}", err=True)


@calibrate_app.command("tracker")
@user_errors
def calibrate_tracker(
    ctx: typer.Context,
    measurements: Annotated[Path, typer.Argument(help="MEASUREMENTS.csv.")],
    machine: MachineOption,
    model: ErrorModelOption = None,
    angle_urad: NoiseOption = 20.0,
    range_noise: RangeNoiseOption = None,
    angle_spread: SpreadOption = None,
    smr: SmrOption = None,
    tool: Annotated[list[str] | None, typer.Option("--tool", help=TOOL_ID_HELP)] = None,
    pose: Annotated[Path | None, typer.Option("--pose", help=KNOWN_POSE_HELP)] = None,
    conditions: Annotated[Path | None, typer.Option("--conditions", help=CONDITIONS_HELP)] = None,
    keep_a_priori: KeepAPrioriOption = False,
    json: Annotated[bool, typer.Option("--json", help="Print RESULT.json.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="RESULT.json.")] = None,
    report_path: ReportOption = None,
) -> None:
    """Identify the error functions (with covariance) and the tracker pose; name what the
    set-up cannot see and what to add, and the constants it exposes (added).  When the
    residuals contradict the noise model (chi-squared p < 0.01) the output says so and the
    covariance is scaled by s² (unless --keep-a-priori-covariance)."""
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.tracker import calibrate, files, read_measurements

    m = Machine.load(machine, model)
    noise = files.noise(angle_urad, range_noise, angle_spread, smr)
    known, known_cov = files.load_known_pose(pose)
    meas = read_measurements(measurements, parse_tools(tool), m)
    cal = calibrate(
        m,
        meas,
        noise=noise,
        conditions=files.load_conditions(conditions),
        pose=known,
        pose_covariance=known_cov,
        adequacy=adequacy_rule(keep_a_priori),
    )
    doc = cal.to_dict()
    report = None
    if report_path is not None:
        from mtmetrology.tracker.report import calibration_report

        report = calibration_report(cal, command_line(ctx), [measurements])
    emit_result(
        doc, cal.summary(), output=output, report=report, report_path=report_path, as_json=json
    )


@verify_app.command("tracker")
@user_errors
def verify_tracker(
    ctx: typer.Context,
    machine: MachineOption,
    mesh: Annotated[str, typer.Option("--mesh", help=MESH_HELP)] = (
        "800:1200:100,100:500:100,200:400:100"
    ),
    truth: Annotated[
        Path | None, typer.Option("--truth", help="TRUTH.json parameter set (zero if omitted).")
    ] = None,
    pose: Annotated[Path | None, typer.Option("--pose", help=POSE_HELP)] = None,
    tools: Annotated[Path | None, typer.Option("--tools", help=TOOLS_HELP)] = None,
    trials: Annotated[int, typer.Option("--trials", help="Simulated verifications.")] = 1000,
    angle_urad: NoiseOption = 20.0,
    range_noise: RangeNoiseOption = None,
    angle_spread: SpreadOption = None,
    smr: SmrOption = None,
    conditions: Annotated[Path | None, typer.Option("--conditions", help=CONDITIONS_HELP)] = None,
    seed: Annotated[int | None, typer.Option("--seed", help="Random seed.")] = None,
    json: Annotated[bool, typer.Option("--json", help="Print RESULT.json.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="RESULT.json.")] = None,
    report_path: ReportOption = None,
) -> None:
    """Monte Carlo of the whole verification: per-point initial and final errors, statistics
    of the mean final volumetric error (mean, σ, mean + 2σ, maximum), distribution fits,
    held-out coverage of the predicted uncertainty."""
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.tracker import files, parse_mesh
    from mtmetrology.tracker.verify import verify

    m = Machine.load(machine)
    with progress_bar("simulated verifications") as progress:
        result = verify(
            m,
            files.true_errors(m, truth),
            files.load_pose(pose),
            parse_mesh(mesh, m),
            files.load_tools(tools),
            trials=trials,
            noise=files.noise(angle_urad, range_noise, angle_spread, smr),
            conditions=files.load_conditions(conditions),
            seed=seed,
            progress=progress,
        )
    doc = result.to_dict()
    report = None
    if report_path is not None:
        from mtmetrology.tracker.report import verification_report

        report = verification_report(result, command_line(ctx))
    emit_result(
        doc, result.summary(), output=output, report=report, report_path=report_path, as_json=json
    )


def _region(text: str):
    parts = [p.split(":") for p in text.split(",")]
    try:
        region = [(float(a), float(b)) for a, b in parts]
    except ValueError:
        region = []
    if len(region) != 3:
        raise InputError(f"--region needs D0:D1,L0:L1,H0:H1 in mm, got {text!r}")
    return tuple(region)


@design_app.command("tracker-placement")
@user_errors
def tracker_placement(
    ctx: typer.Context,
    machine: MachineOption,
    mesh: Annotated[str, typer.Option("--mesh", help=MESH_HELP)] = (
        "800:1200:100,100:500:100,200:400:100"
    ),
    tools: Annotated[Path | None, typer.Option("--tools", help=TOOLS_HELP)] = None,
    region: Annotated[
        str, typer.Option("--region", help="Allowed tracker region D0:D1,L0:L1,H0:H1, mm.")
    ] = "-2000:-500,-2000:2000,350:2000",
    direction: Annotated[
        str, typer.Option("--direction", help="x: tracker on the -X side; y: on the -Y side.")
    ] = "x",
    criterion: Annotated[
        str, typer.Option("--criterion", help="max or mean of u_p over the mesh.")
    ] = "max",
    trials: Annotated[int, typer.Option("--trials", help="Candidate poses drawn.")] = 10_000,
    seed: Annotated[int | None, typer.Option("--seed", help="Random seed.")] = None,
    json: Annotated[bool, typer.Option("--json", help="Print RESULT.json.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="RESULT.json.")] = None,
    report_path: ReportOption = None,
) -> None:
    """Placement study of the tracker over the allowed region: criterion per candidate pose,
    colour map, best pose (refusing poses inside the workspace or beyond the limits)."""
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.tracker import files, parse_mesh
    from mtmetrology.tracker.placement import plan_placement

    m = Machine.load(machine)
    study = plan_placement(
        m,
        parse_mesh(mesh, m),
        files.load_tools(tools),
        region=_region(region),
        direction=direction,
        criterion=criterion,
        trials=trials,
        seed=seed,
    )
    doc = study.to_dict()
    report = None
    if report_path is not None:
        from mtmetrology.tracker.report import placement_report

        report = placement_report(study, command_line(ctx))
    emit_result(
        doc, study.summary(), output=output, report=report, report_path=report_path, as_json=json
    )
