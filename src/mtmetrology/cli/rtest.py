"""``mtm rtest simulate|calibrate``: the static R-test of the rotary axes (ISO 10791-6 style).

Each command parses its options, calls one library function of
:mod:`mtmetrology.rtest.requests`, and prints (or writes) the result; the library is
imported inside the commands.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from mtmetrology.cli._common import (
    KeepAPrioriOption,
    MachineOption,
    adequacy_rule,
    emit_result,
    user_errors,
    vector_option,
)

app = typer.Typer(
    help="Static R-test of the rotary axes: simulate, calibrate (location errors and error "
    "motions by rank).",
    no_args_is_help=True,
)

SphereOption = Annotated[
    str,
    typer.Option("--sphere", help="Nominal sphere centre x,y,z in the workpiece frame, mm."),
]
SensorsOption = Annotated[
    Path | None,
    typer.Option(
        "--sensors",
        help="SENSORS.yaml (kind rtest-sensors: directions in the tool frame, gains); three "
        "orthogonal sensors along +X, +Y, +Z with gain 1 if omitted.",
    ),
]


@app.command("simulate")
@user_errors
def simulate(
    machine: MachineOption,
    output: Annotated[Path, typer.Option("-o", "--output", help="READINGS.csv to write.")],
    index: Annotated[
        list[str],
        typer.Option("--index", help="AXIS=start:stop:step in degrees (B=-60:60:30). Repeatable."),
    ],
    sphere: SphereOption = "100,0,50",
    sensors: SensorsOption = None,
    error: Annotated[
        list[str] | None,
        typer.Option("--error", help="NAME=VALUE true error (E_X0C=10 µm). Repeatable."),
    ] = None,
    noise_um: Annotated[float, typer.Option("--noise-um", help="Sensor noise σ, µm.")] = 0.0,
    seed: Annotated[int | None, typer.Option("--seed", help="Random seed.")] = None,
) -> None:
    """Write the sensor readings of a virtual R-test over a grid of indexations."""
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.rtest.requests import load_sensors, simulate_file, values_from_pairs
    from mtmetrology.units import to_internal

    m = Machine.load(machine)
    n = simulate_file(
        m,
        index,
        vector_option(sphere, "--sphere"),
        load_sensors(sensors),
        values_from_pairs(m, error or [], "--error"),
        output,
        noise=to_internal(noise_um, "µm"),
        seed=seed,
    )
    typer.echo(f"wrote {n} R-test indexations to {output}", err=True)


@app.command("calibrate")
@user_errors
def calibrate(
    readings: Annotated[
        Path, typer.Argument(help="READINGS.csv: axis readings (mm, deg) and s1_um, s2_um, ...")
    ],
    machine: MachineOption,
    sphere: SphereOption = "100,0,50",
    sensors: SensorsOption = None,
    params: Annotated[
        str | None,
        typer.Option(
            "--params",
            help="Candidate ISO 230-1 parameters (E_X0C,E_XC2,...); the rotary axes' location "
            "errors if omitted. Those the programme cannot separate are dropped and named.",
        ),
    ] = None,
    sigma_um: Annotated[
        float | None,
        typer.Option("--sigma-um", help="Sensor σ, µm; from the residuals if omitted."),
    ] = None,
    keep_a_priori: KeepAPrioriOption = False,
    json: Annotated[bool, typer.Option("--json", help="Print RESULT.json.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="RESULT.json.")] = None,
) -> None:
    """Identify the rotary axes' location errors (and error motions) with their uncertainty
    (k = 2); the programme's rank decides what is identifiable, named with what absorbs
    the rest."""
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.rtest.requests import calibrate_file, calibration_summary, load_sensors
    from mtmetrology.units import to_internal

    m = Machine.load(machine)
    result = calibrate_file(
        m,
        readings,
        load_sensors(sensors),
        sphere=vector_option(sphere, "--sphere"),
        parameters=None if params is None else [p.strip() for p in params.split(",")],
        sigma=None if sigma_um is None else to_internal(sigma_um, "µm"),
        adequacy=adequacy_rule(keep_a_priori),
    )
    emit_result(
        result.to_dict(machine),
        calibration_summary(result),
        output=output,
        report=None,
        report_path=None,
        as_json=json,
    )
