"""``mtm length verify`` and ``mtm length predict``: independent checks of a calibrated machine
(commands of the ``mtm length`` group, :data:`mtmetrology.cli.SHARED_GROUPS`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from mtmetrology.cli._common import (
    MachineOption,
    ReportOption,
    emit_result,
    machine_with_parameters,
    user_errors,
)
from mtmetrology.cli.calibrate import samba_report
from mtmetrology.errors import InputError

app = typer.Typer(help="Independent checks of a calibrated machine.", no_args_is_help=True)

LENGTH_HELP = """Gauge-block length check before and after compensation.

READINGS.csv (mm, degrees): pair,end,X,Y,Z,B,C[,S], end a or b: each pair of rows puts
the stylus centre against the two end faces of the calibrated length at one (B, C).

Each pair's length is the distance of the two stylus centres (forward kinematics of
the nominal model and of the compensated model RESULT.json) less the tip diameter;
its error is length - L. Reports each pair's nominal and compensated error and their
mean, RMS, standard deviation, range and largest magnitude (µm); --json prints the
length-check document, -o writes it. u(e) of each compensated error holds the gauge's
u (--u-length, thermal, tip) and the calibration's, g U_θ gᵀ from the covariance of
RESULT.json.
"""


@app.command("length", help=LENGTH_HELP)
@user_errors
def length(
    ctx: typer.Context,
    readings: Annotated[Path, typer.Argument(help="READINGS.csv: pair,end,X,Y,Z,B,C[,S].")],
    machine: MachineOption,
    length_mm: Annotated[float, typer.Option("--length", help="Calibrated length L, mm.")],
    params: Annotated[
        Path | None, typer.Option("--params", help="RESULT.json or a parameter set.")
    ] = None,
    u_length: Annotated[
        float | None, typer.Option("--u-length", help="Standard uncertainty of L, mm.")
    ] = None,
    tip_radius_mm: Annotated[
        float | None,
        typer.Option("--tip-radius-mm", help="Effective tip radius (machine file's if omitted)."),
    ] = None,
    temperature_c: Annotated[
        float | None,
        typer.Option("--temperature-c", help="Gauge temperature during the check, °C."),
    ] = None,
    u_temperature_c: Annotated[
        float, typer.Option("--u-temperature-c", help="Standard uncertainty of it, °C.")
    ] = 0.0,
    cte: Annotated[
        float, typer.Option("--cte", help="Gauge expansion coefficient, µm/(m·°C).")
    ] = 10.8,
    u_cte: Annotated[float, typer.Option("--u-cte", help="Its standard uncertainty.")] = 0.0,
    tip_sphere: Annotated[
        Path | None,
        typer.Option("--tip-sphere", help="Stylus-centre points x,y,z (mm) on a reference sphere."),
    ] = None,
    sphere_diameter: Annotated[
        float | None, typer.Option("--sphere-diameter", help="Its calibrated diameter, mm.")
    ] = None,
    u_sphere_diameter: Annotated[
        float, typer.Option("--u-sphere-diameter", help="Standard uncertainty of it, mm.")
    ] = 0.0,
    sigma_points_um: Annotated[
        float | None,
        typer.Option("--sigma-points-um", help="Probing repeatability of the sphere points."),
    ] = None,
    json: Annotated[bool, typer.Option("--json", help="Print the JSON document.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="JSON file.")] = None,
    report_path: ReportOption = None,
) -> None:
    from mtmetrology.fitting.least_squares import FitError
    from mtmetrology.fitting.probe import effective_tip_diameter
    from mtmetrology.formatting import format_uncertainty
    from mtmetrology.io.tables import read_csv_table
    from mtmetrology.samba import read_length_readings, verify_length
    from mtmetrology.samba.verify import thermal_reference
    from mtmetrology.units import to_internal

    if u_length is not None and not u_length >= 0:
        raise InputError(f"--u-length must be >= 0, got {u_length}")
    if (tip_sphere is None) != (sphere_diameter is None):
        raise InputError("--tip-sphere and --sphere-diameter go together")
    if tip_sphere is not None and tip_radius_mm is not None:
        raise InputError("give --tip-radius-mm or --tip-sphere, not both")
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.parameter_set import ParameterSet

    m, theta = machine_with_parameters(machine, params)
    # U_θ of the set, in its parameter order: the order machine_for gave m
    covariance = (
        None if params is None else ParameterSet.load(params, Machine.load(machine)).covariance
    )
    data = read_length_readings(readings, m)
    thermal = None
    if temperature_c is not None:
        thermal = thermal_reference(
            length_mm, u_length or 0.0, temperature_c, u_temperature_c, cte * 1e-6, u_cte * 1e-6
        )
    tip_radius, u_tip = (m.tip_radius if tip_radius_mm is None else tip_radius_mm), None
    if tip_sphere is not None:
        points = read_csv_table(tip_sphere, required=["x", "y", "z"]).vectors(["x", "y", "z"])
        sigma = None if sigma_points_um is None else to_internal(sigma_points_um, "µm")
        try:
            tip = effective_tip_diameter(points, sphere_diameter, u_sphere_diameter, sigma)
        except FitError as err:
            raise InputError(f"{tip_sphere}: {err}") from None
        tip_radius, u_tip = tip.radius, tip.u
    check = verify_length(
        m,
        theta,
        data,
        length_mm,
        tip_radius=tip_radius,
        u_length=u_length,
        thermal=thermal,
        u_tip_diameter=u_tip,
        parameter_covariance=covariance,
    )
    doc = check.to_dict()
    report = None
    if report_path is not None:
        inputs = [readings, machine if not Path(machine).is_file() else Path(machine)]
        if params is not None:
            inputs.append(params)
        report = samba_report(ctx, f"Gauge-length check: {readings.name}", inputs, check)

    def summary() -> None:
        typer.echo(f"length check, L = {length_mm} mm, {len(check.pairs)} pairs (errors in µm)")
        for name in ("nominal", "compensated"):
            s = doc[name]
            typer.echo(
                f"  {name:<12} mean {s['mean']:9.3f}  rms {s['rms']:9.3f}  "
                f"max |e| {s['max_abs']:9.3f}  range {s['range']:9.3f}"
            )
        if doc["thermal"] is not None:
            t = doc["thermal"]
            typer.echo(
                f"  reference L_T = {t['length_mm']:.5f} mm at {temperature_c:g} °C "
                f"(sensitivity {1e3 * t['sensitivities']['temperature']:.2f} µm/°C)"
            )
        if doc["u_tip_diameter_mm"] is not None:
            typer.echo(f"  tip radius {doc['tip_radius_mm']:.5f} mm from the reference sphere")
        u_errors = [p["u_error_um"] for p in doc["pairs"] if p["u_error_um"] is not None]
        if u_errors:
            gauge = doc["u_gauge_um"] or 0.0
            calibration = (
                "the calibration's U_θ per pair"
                if doc["calibration_in_u"]
                else "no calibration part: the parameter set has no covariance"
                if params is not None
                else "no calibration part: no --params"
            )
            low, high = format_uncertainty(min(u_errors)), format_uncertainty(max(u_errors))
            typer.echo(
                f"  u(e) of the compensated errors {low if low == high else f'{low} to {high}'} "
                f"µm (gauge {format_uncertainty(gauge)} µm; {calibration})"
            )

    emit_result(doc, summary, output=output, report=report, report_path=report_path, as_json=json)


LENGTHS_HELP = """Lengths between pairs of positions predicted by a calibration, with u(L).

READINGS.csv (mm, degrees): pair,end,X,Y,Z[,B,C,S], end a or b: the two commanded
positions of each pair. Each length is L = |p(b) - p(a)| of the tool tip with the
calibrated errors (RESULT.json: a parameter set with its covariance, e.g. of mtm
tracker calibrate or mtm multilateration calibrate), and u(L)^2 = g U_θ g^T with
g = dL/dθ (both ends share θ: their correlation is kept; readings taken as exact).
U = 2 u(L) (k = 2).
--reference REF.csv (pair,length_mm,u_um) adds each pair's error L - L_ref and
E_n = |e| / (2 sqrt(u(L)^2 + u_ref^2)).
"""


@app.command("lengths", help=LENGTHS_HELP)
@user_errors
def lengths(
    readings: Annotated[Path, typer.Argument(help="READINGS.csv: pair,end,X,Y,Z[,B,C,S].")],
    machine: MachineOption,
    params: Annotated[
        Path, typer.Option("--params", help="RESULT.json or a parameter set with covariance.")
    ],
    tool: Annotated[
        str | None, typer.Option("--tool", help="Tool vector x,y,z, mm (the machine's if omitted).")
    ] = None,
    reference: Annotated[
        Path | None, typer.Option("--reference", help="REF.csv: pair,length_mm,u_um.")
    ] = None,
    json: Annotated[bool, typer.Option("--json", help="Print the JSON document.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="JSON file.")] = None,
) -> None:
    from mtmetrology.cli._common import vector_option
    from mtmetrology.io import InputFileError
    from mtmetrology.kinematics.lengths import pair_lengths, read_reference_lengths
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.parameter_set import ParameterSet
    from mtmetrology.samba import read_length_readings

    base = Machine.load(machine)
    pset = ParameterSet.load(params, base)
    if pset.covariance is None:
        raise InputFileError(f"{params}: no covariance; u(L) needs the calibration's U_θ")
    m = pset.machine_for(base)
    data = read_length_readings(readings, m)
    ref = (None, None) if reference is None else read_reference_lengths(reference, data.pairs)
    result = pair_lengths(
        m,
        pset.vector_for(m),
        pset.covariance,
        data.end_a,
        data.end_b,
        tool=None if tool is None else vector_option(tool, "--tool"),
        names=data.pairs,
        reference=ref[0],
        u_reference=ref[1],
    )
    emit_result(result.to_dict(), result.summary(), output=output, report=None,
                report_path=None, as_json=json)  # fmt: skip
