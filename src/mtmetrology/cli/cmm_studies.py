"""``mtm cmm``: bridge-CMM studies of the source (Salacheep 2016).

``compare``: kinematic against GP error model on held-out plate positions;
``source-gp``: the source's GP demonstration re-run (GPML port, :mod:`mtmetrology.cmm.gpml`);
``selfcal-design``: U1, U2, U3 of the source's self-calibration (:mod:`mtmetrology.cmm.selfcal`);
``calibrate``: the ball-plate calibration, by the probe set's stylus offsets
(:func:`mtmetrology.cli.cmm.calibrate_ballplate`) or, with ``--qualification``, with the
stylus offsets (and optionally the plate) as unknowns (:mod:`mtmetrology.cmm.probecal`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from mtmetrology.cli._common import (
    KeepAPrioriOption,
    MachineOption,
    ReportOption,
    emit_result,
    user_errors,
)
from mtmetrology.cli._history import HistoryOption
from mtmetrology.cli.cmm import (
    FILES_HELP,
    PlateOpt,
    ProbesOpt,
    SigmaOpt,
    add_cmm_result,
    calibrate_ballplate,
    cmm_report,
    positive_option,
    read_ballplate_inputs,
)
from mtmetrology.cmm.requests import AUTO_CANDIDATES
from mtmetrology.io.files import InputFileError, check_output

if TYPE_CHECKING:
    from mtmetrology.cmm.probecal import CalibratedLength

__all__ = ["app"]

app = typer.Typer(help="Bridge-CMM studies on ball-plate records.", no_args_is_help=True)


def _emit(ctx, result, title, inputs, machine, *, output, report_path, as_json, messages):
    """The end of a study: its JSON (``-o``, ``--json``), its report when asked for (command
    line and inputs as provenance) and its console lines on standard error."""
    report = None
    if report_path is not None:
        report = cmm_report(ctx, title, inputs, machine)
        add_cmm_result(report, result)
    emit_result(
        result.to_dict(),
        None,
        output=output,
        report=report,
        report_path=report_path,
        as_json=as_json,
        messages=messages,
    )


@app.command("compare")
@user_errors
def compare(
    ctx: typer.Context,
    records: Annotated[Path, typer.Argument(help="Records CSV: position,ball,probe,X,Y,Z (mm).")],
    machine: MachineOption,
    plate: PlateOpt,
    probes: ProbesOpt,
    held_out: Annotated[
        list[str], typer.Option("--held-out", help="Position left out of both fits (repeatable).")
    ],
    model: Annotated[str, typer.Option("--model", help="Kinematic model: seed, full-<d>.")] = (
        "full-3"
    ),
    gp_mean: Annotated[
        str, typer.Option("--gp-mean", help="GP mean: seed, full-<d>, or none (zero mean).")
    ] = "seed",
    kernel: Annotated[str, typer.Option("--kernel", help="rbf (squared exp.) or matern.")] = "rbf",
    sigma_um: SigmaOpt = 0.5,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Write the result (JSON).")
    ] = None,
    json_out: Annotated[bool, typer.Option("--json", help="Also print the result.")] = False,
    report_path: ReportOption = None,
) -> None:
    """Fit the kinematic model and the GP without the held-out positions; compare both on
    every length between two balls of a held-out position (same stylus) against the plate
    certificate: RMS and max length error, mean u, coverage of ±2u."""
    from mtmetrology.cmm.heldout import compare_held_out
    from mtmetrology.cmm.models import parse_model
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.units import to_internal

    sigma = to_internal(positive_option(sigma_um, "--sigma-um"), "µm")
    if output is not None:
        check_output(output, [records, plate, probes])
    m = Machine.load(machine)
    rec, pl, pr = read_ballplate_inputs(records, plate, probes)
    choice = parse_model(model)
    if gp_mean != "none":
        parse_model(gp_mean, option="--gp-mean", others=("none",))
    if kernel not in ("rbf", "matern"):
        raise InputFileError(f"--kernel {kernel!r}: use rbf or matern")
    res = compare_held_out(
        m,
        rec,
        pl,
        pr,
        held_out,
        sigma=sigma,
        kinematic_model=choice,
        gp_mean=None if gp_mean == "none" else gp_mean,
        kernel=kernel,
    )

    def messages() -> None:
        for r in res.table:
            typer.echo(
                f"{r['model']}: {r['n_lengths']} lengths, rms {r['rms_error_um']:.2g} µm, "
                f"max {r['max_error_um']:.2g} µm, mean u {r['mean_u_um']:.2g} µm, "
                f"{100 * r['coverage']:.0f} % within ±{r['coverage_factor']:g}u",
                err=True,
            )

    title = f"Kinematic versus GP: {records.name}"
    _emit(
        ctx,
        res,
        title,
        [records, plate, probes],
        machine,
        output=output,
        report_path=report_path,
        as_json=json_out,
        messages=messages,
    )


@app.command("source-gp")
@user_errors
def source_gp(
    ctx: typer.Context,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Write the result (JSON).")
    ] = None,
    json_out: Annotated[bool, typer.Option("--json", help="Also print the result.")] = False,
    report_path: ReportOption = None,
) -> None:
    """Re-run the source's GP (Ch. 5, Appendix 3): GPML's gpml_randn(0.01, 9) data, the
    zero-mean SE GP from [0, 0, log 0.1] and the quadratic-mean GP (eq. 5.11) from the
    source's start; the largest difference of their means on the 21 x 21 grid."""
    from mtmetrology.cmm.gpml import source_gp_demo

    if output is not None:
        check_output(output)
    res = source_gp_demo()
    doc = res.to_dict()

    def messages() -> None:
        for name, gp in (("zero mean", res.zero_mean), ("quadratic mean", res.quadratic_mean)):
            hyp = ", ".join(f"{v:.6f}" for v in gp.hyperparameters)
            typer.echo(f"{name}: hyp [{hyp}], NLML {gp.nlml:.5f}", err=True)
        at = doc["max_difference_at"]
        typer.echo(
            f"max |m_zero - m_quad| = {res.max_difference:.5f} at ({at[0]:.2f}, {at[1]:.2f})",
            err=True,
        )

    _emit(
        ctx,
        res,
        "The source's GP re-run",
        [],
        None,
        output=output,
        report_path=report_path,
        as_json=json_out,
        messages=messages,
    )


@app.command("selfcal-design")
@user_errors
def selfcal_design_cmd(
    ctx: typer.Context,
    machine: MachineOption,
    locations: Annotated[
        str, typer.Option("--locations", help="Plate locations, comma-separated: L0, L1, L2.")
    ] = "L0,L1,L2",
    truncation: Annotated[
        int, typer.Option("--truncation", help="K of the truncated SVD (the source: 36).")
    ] = 36,
    sigma_um: SigmaOpt = 0.5,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the U2/U3 points.")] = 0,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Write the result (JSON).")
    ] = None,
    json_out: Annotated[bool, typer.Option("--json", help="Also print the result.")] = False,
    report_path: ReportOption = None,
    balls_per_side: Annotated[
        int, typer.Option("--balls-per-side", help="n of the n x n plate (Table 4.3: 3 or 5).")
    ] = 3,
    pitch_mm: Annotated[float, typer.Option("--pitch-mm", help="Ball pitch, mm.")] = 100.0,
) -> None:
    """U1, U2, U3 of the source's self-calibration design (3 x 3 plate at 100 mm pitch, six
    styli at +-50 mm, reference sphere; ball centres, stylus offsets and poses unknown; the
    plate frame, one length and the stylus centroid fixed): full covariance and truncated
    SVD, and what each constraint leaves free."""
    from mtmetrology.cmm.selfcal import TABLE_4_3, THESIS_TABLES, selfcal_design
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.units import to_internal

    sigma = to_internal(positive_option(sigma_um, "--sigma-um"), "µm")
    if output is not None:
        check_output(output)
    m = Machine.load(machine)
    locs = [s.strip() for s in locations.split(",") if s.strip()]
    res = selfcal_design(
        m,
        locs,
        sigma=sigma,
        truncation=truncation,
        seed=seed,
        balls_per_side=balls_per_side,
        pitch_mm=pitch_mm,
    )

    def messages() -> None:
        key = "+".join(locs)
        typer.echo(
            f"{key}: {res.n_unknowns} unknowns, {res.n_constraints} constraints, rank {res.rank}"
            f" ({'full' if res.full_rank else 'deficient'})",
            err=True,
        )
        for label, table in (("full", res.U_full), (f"K = {truncation}", res.U_truncated)):
            if table is None:
                free = res.freedoms["all constraints"]["message"]
                typer.echo(f"{label}: no full covariance: {free}", err=True)
                continue
            parts = "; ".join(f"{u} {'/'.join(f'{v:.2g}' for v in table[u])}" for u in table)
            typer.echo(f"{label}: {parts} µm (x/y/z)", err=True)
        pub, table = THESIS_TABLES.get(key), "Tables 4.1-4.2"
        if balls_per_side != 3 or pitch_mm != 100.0:
            pub, table = TABLE_4_3.get(balls_per_side) if key == "L1" else None, "Table 4.3"
        if pub is not None:
            parts = "; ".join(f"{u} {'/'.join(f'{v:.2g}' for v in pub[u])}" for u in pub)
            typer.echo(f"source ({table}): {parts} µm", err=True)

    _emit(
        ctx,
        res,
        "Self-calibration design",
        [],
        machine,
        output=output,
        report_path=report_path,
        as_json=json_out,
        messages=messages,
    )


def _length(text: str) -> CalibratedLength:
    from mtmetrology.cmm.probecal import CalibratedLength
    from mtmetrology.units import to_internal

    parts = [p.strip() for p in text.split(",")]
    try:
        a, b, length, u_um = parts[0], parts[1], float(parts[2]), float(parts[3])
    except (IndexError, ValueError):
        raise InputFileError(
            f"--length {text!r}: give BALL_A,BALL_B,LENGTH_MM,U_UM (e.g. 00,08,752.3,0.2)"
        ) from None
    if len(parts) != 4 or not (length > 0 and u_um > 0):
        raise InputFileError(f"--length {text!r}: LENGTH_MM and U_UM must be positive")
    return CalibratedLength(a, b, length, to_internal(u_um, "µm"))


CALIBRATE_HELP = f"""Identify a CMM's error functions from ball-plate records (kinematic model).

Unknowns: the error parameters, 6 pose parameters per plate position and the ball
centres (the certificate enters with its uncertainty). The datum (terms left out) is
chosen by rank and reported; a set-up that cannot see the model is refused with the
unobservable combinations named. Writes a ballplate-calibration result (a parameter set
for `mtm predict --params`) with U1/U2/U3 from the full covariance, scaled by the
variance factor s² when the residuals contradict the model or --sigma-um (chi-squared
p < 0.01; --keep-a-priori-covariance keeps it); residual RMS by position and stylus.

With --qualification, the stylus offsets are unknowns too: the qualification records on a
reference sphere are observations of their own, the stylus centroid is fixed; the plate by
its certificate or, with --length, self-calibrated with one length as its only scale. A
set-up that leaves directions free is refused with them named (--model seed or full-<d>;
--degrees, --candidates, --seed, --keep-a-priori-covariance and --history are for the
calibration without --qualification).

{FILES_HELP}"""


@app.command("calibrate", help=CALIBRATE_HELP)
@user_errors
def calibrate_cmd(
    ctx: typer.Context,
    records: Annotated[Path, typer.Argument(help="Records CSV: position,ball,probe,X,Y,Z (mm).")],
    machine: MachineOption,
    plate: PlateOpt,
    probes: ProbesOpt,
    output: Annotated[Path, typer.Option("-o", "--output", help="Write the result (JSON).")],
    qualification: Annotated[
        Path | None,
        typer.Option(
            "--qualification",
            help="Reference-sphere records, CSV position,ball,probe,X,Y,Z (mm): every stylus; "
            "the stylus offsets become unknowns.",
        ),
    ] = None,
    model: Annotated[
        str,
        typer.Option(
            "--model",
            help="seed (the source's Chebyshev model), full-<d> (21 functions, degree <= d), "
            "or auto (lowest median held-out RMS over folds that hold out a block of balls "
            "in every plate position; lowest AIC when no fair comparison is possible).",
        ),
    ] = "seed",
    degrees: Annotated[
        str | None,
        typer.Option("--degrees", help="Per-function degrees of a full model: E_YX=3,E_AZ=1."),
    ] = None,
    candidates: Annotated[
        str,
        typer.Option("--candidates", help="Models compared by --model auto, comma-separated."),
    ] = ",".join(AUTO_CANDIDATES),
    length: Annotated[
        str | None,
        typer.Option(
            "--length",
            help="With --qualification: self-calibrate the plate with one calibrated length: "
            "BALL_A,BALL_B,LENGTH_MM,U_UM (the certificate's centres are then only the start).",
        ),
    ] = None,
    sigma_um: SigmaOpt = 0.5,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the U2/U3 sample points.")] = 0,
    keep_a_priori: KeepAPrioriOption = False,
    json_out: Annotated[bool, typer.Option("--json", help="Also print the result.")] = False,
    report_path: ReportOption = None,
    history: HistoryOption = False,
) -> None:
    if qualification is None:
        if length is not None:
            raise InputFileError("--length: needs --qualification (the styli as unknowns)")
        calibrate_ballplate(
            ctx, records, machine, plate, probes, output, model=model, degrees=degrees,
            candidates=candidates, sigma_um=sigma_um, seed=seed, keep_a_priori=keep_a_priori,
            json_out=json_out, report_path=report_path, history=history,
        )  # fmt: skip
        return
    not_here = [
        option
        for option, given in (
            ("--model auto", model == "auto"),
            ("--degrees", degrees is not None),
            ("--candidates", candidates != ",".join(AUTO_CANDIDATES)),
            ("--seed", seed != 0),
            ("--keep-a-priori-covariance", keep_a_priori),
            ("--history", history),
        )
        if given
    ]
    if not_here:
        raise InputFileError(f"{not_here[0]}: not with --qualification (styli as unknowns)")
    from mtmetrology.cmm.files import read_records
    from mtmetrology.cmm.models import parse_model
    from mtmetrology.cmm.probecal import calibrate_with_probes
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.units import to_internal

    sigma = to_internal(positive_option(sigma_um, "--sigma-um"), "µm")
    check_output(output, [records, plate, probes, qualification])
    m = Machine.load(machine)
    rec, pl, pr = read_ballplate_inputs(records, plate, probes)
    qual = read_records(qualification)
    for i, pid in enumerate(qual.probes):
        if pid not in pr.ids:
            raise InputFileError(
                f"{qualification}, line {qual.lines[i]}: probe {pid!r} is not in the probe set"
            )
    res = calibrate_with_probes(
        m,
        rec,
        pl,
        pr,
        qual,
        sigma=sigma,
        model=parse_model(model),
        length=None if length is None else _length(length),
    )
    inputs = [records, plate, probes, qualification]
    title = f"Styli and plate as unknowns: {records.name}"

    def messages() -> None:
        for pid, p in res.probes.items():
            corr = "/".join(f"{v:+.2g}" for v in p["correction_um"])
            u = "/".join(f"{v:.2g}" for v in p["u_um"])
            typer.echo(f"stylus {pid}: correction {corr} µm (u {u} µm)", err=True)
        typer.echo(
            f"{res.model}, plate by {res.plate}: rms residual "
            f"{res.fit['rms_residual_um']:.2g} µm; wrote {output}",
            err=True,
        )

    _emit(
        ctx,
        res,
        title,
        inputs,
        machine,
        output=output,
        report_path=report_path,
        as_json=json_out,
        messages=messages,
    )
