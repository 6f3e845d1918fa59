"""``mtm ballbar simulate|analyse|calibrate``: ISO 230-4 circular tests with a ballbar.

Each command parses its options, calls one library function of
:mod:`mtmetrology.ballbar.requests`, and prints (or writes) the result; the library is
imported inside the commands.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from mtmetrology.cli._common import (
    KeepAPrioriOption,
    MachineOption,
    ReportOption,
    adequacy_rule,
    command_line,
    emit_result,
    user_errors,
    vector_option,
)

app = typer.Typer(
    help="ISO 230-4 circular tests with a ballbar: simulate, analyse (G, H, F), calibrate "
    "(identify the plane's ISO 230-1 errors and servo terms).",
    no_args_is_help=True,
)

TESTS_HELP = (
    "The neutral CSV (angle_deg, direction ccw/cw, reading_um, X, Y, Z) with --plane, "
    "--radius, --feed, --centre; or a tests file (YAML, kind ballbar-tests) listing several."
)
PlaneOption = Annotated[
    str | None, typer.Option("--plane", help="XY, YZ or ZX (angle from the first axis).")
]
RadiusOption = Annotated[float | None, typer.Option("--radius", help="Nominal radius R, mm.")]
FeedOption = Annotated[float | None, typer.Option("--feed", help="Contouring feed, mm/min.")]
CentreOption = Annotated[
    str | None, typer.Option("--centre", help="Commanded centre X,Y,Z, mm (e.g. 0,0,0).")
]
OvershootOption = Annotated[
    float, typer.Option("--overshoot-deg", help="Arc of overshoot before and after, degrees.")
]
NameOption = Annotated[str, typer.Option("--name", help="Test id.")]
JsonOption = Annotated[bool, typer.Option("--json", help="Print RESULT.json.")]
OutputOption = Annotated[Path | None, typer.Option("-o", "--output", help="RESULT.json.")]


def _conditions(plane, radius, feed, centre, overshoot, name):
    from mtmetrology.ballbar.requests import conditions_from_options

    xyz = None if centre is None else vector_option(centre, "--centre")
    return conditions_from_options(plane, radius, feed, xyz, overshoot, name)


@app.command("simulate")
@user_errors
def simulate(
    machine: MachineOption,
    output: Annotated[Path, typer.Option("-o", "--output", help="TEST.csv to write.")],
    plane: PlaneOption = "XY",
    radius: RadiusOption = 100.0,
    feed: FeedOption = 1000.0,
    centre: CentreOption = "0,0,0",
    overshoot_deg: OvershootOption = 0.0,
    name: NameOption = "test",
    error: Annotated[
        list[str] | None,
        typer.Option(
            "--error",
            help="NAME=VALUE true error in display units (E_C0Y=20 µrad, E_XX1=10 µm/m on a "
            "monomial basis, servo_mismatch_XY=1 ms, reversal_spike_X=3 µm). Repeatable.",
        ),
    ] = None,
    samples: Annotated[int, typer.Option("--samples", help="Samples per direction.")] = 360,
    noise_um: Annotated[float, typer.Option("--noise-um", help="Reading noise σ, µm.")] = 0.0,
    seed: Annotated[int | None, typer.Option("--seed", help="Random seed.")] = None,
) -> None:
    """Write the neutral CSV of a virtual circular test of a machine with known errors."""
    from mtmetrology.ballbar.requests import simulate_file, values_from_pairs
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.units import to_internal

    m = Machine.load(machine)
    cond = _conditions(plane, radius, feed, centre, overshoot_deg, name)
    truth = values_from_pairs(m, error or [], "--error")
    test = simulate_file(
        m, cond, truth, output, n_per_run=samples, noise=to_internal(noise_um, "µm"), seed=seed
    )
    typer.echo(f"wrote {len(test)} ballbar readings to {output}", err=True)


@app.command("analyse")
@user_errors
def analyse(
    ctx: typer.Context,
    tests: Annotated[Path, typer.Argument(help=TESTS_HELP)],
    plane: PlaneOption = None,
    radius: RadiusOption = None,
    feed: FeedOption = None,
    centre: CentreOption = None,
    overshoot_deg: OvershootOption = 0.0,
    name: NameOption = "test",
    machine: Annotated[str | None, typer.Option("--machine", help="Machine name.")] = None,
    json: JsonOption = False,
    output: OutputOption = None,
    report_path: ReportOption = None,
) -> None:
    """ISO 230-4 results per direction: circular deviation G (least-squares centre),
    circular hysteresis H, radial deviation F max/min."""
    from mtmetrology.ballbar.requests import analyse_file

    cond = _conditions(plane, radius, feed, centre, overshoot_deg, name)
    result = analyse_file(tests, cond, machine=machine)
    report = None
    if report_path is not None:
        from mtmetrology.ballbar.report import analysis_report

        report = analysis_report(result, command_line(ctx), [tests])
    emit_result(
        result.to_dict(),
        result.summary(),
        output=output,
        report=report,
        report_path=report_path,
        as_json=json,
    )


@app.command("calibrate")
@user_errors
def calibrate(
    tests: Annotated[Path, typer.Argument(help=TESTS_HELP)],
    machine: MachineOption,
    plane: PlaneOption = None,
    radius: RadiusOption = None,
    feed: FeedOption = None,
    centre: CentreOption = None,
    overshoot_deg: OvershootOption = 0.0,
    name: NameOption = "test",
    params: Annotated[
        str | None,
        typer.Option("--params", help="Identify these ISO 230-1 parameters (E_XX1,E_C0Y,...)."),
    ] = None,
    dynamic: Annotated[
        str, typer.Option("--dynamic", help="Dynamic terms: servo,spike, one of them, or none.")
    ] = "servo,spike",
    uncalibrated_length: Annotated[
        bool,
        typer.Option(
            "--uncalibrated-length", help="The bar length is not calibrated: identify its offset."
        ),
    ] = False,
    sigma_um: Annotated[
        float | None,
        typer.Option("--sigma-um", help="Reading σ, µm; from the residuals if omitted."),
    ] = None,
    min_norm: Annotated[
        bool, typer.Option("--min-norm", help="Minimum-norm solution of a rank-deficient set.")
    ] = False,
    keep_a_priori: KeepAPrioriOption = False,
    json: JsonOption = False,
    output: OutputOption = None,
) -> None:
    """Identify the ISO 230-1 errors of the planes' axes (scale, squareness, straightness,
    reversal) and the servo mismatch and reversal spikes, with their uncertainty (k = 2);
    name what the tests cannot separate and which second test would."""
    from mtmetrology.ballbar.requests import calibrate_files, diagnosis_summary
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.units import to_internal

    m = Machine.load(machine)
    cond = _conditions(plane, radius, feed, centre, overshoot_deg, name)
    kinds = tuple(k.strip() for k in dynamic.split(",") if k.strip() and k.strip() != "none")
    result = calibrate_files(
        m,
        tests,
        cond,
        parameters=None if params is None else [p.strip() for p in params.split(",")],
        dynamic=kinds,
        length_calibrated=not uncalibrated_length,
        sigma=None if sigma_um is None else to_internal(sigma_um, "µm"),
        adequacy=adequacy_rule(keep_a_priori),
        minimum_norm=min_norm,
    )
    emit_result(
        result.to_dict(machine),
        diagnosis_summary(result),
        output=output,
        report=None,
        report_path=None,
        as_json=json,
    )
