"""CMM commands: ``mtm cmm simulate``, ``mtm cmm budget``, ``mtm gp fit``,
``mtm gp predict``, and the ball-plate calibration that ``mtm cmm calibrate``
(:mod:`mtmetrology.cli.cmm_studies`) runs without ``--qualification``.

:data:`app` holds this module's commands of the ``mtm cmm`` group
(:data:`mtmetrology.cli.SHARED_GROUPS`); ``gp`` is this module's own group, :data:`gp_app`.
"""

from __future__ import annotations

import inspect
import math
from pathlib import Path
from typing import Annotated

import typer

from mtmetrology.cli._common import (
    CoverageK,
    CoverageP,
    MachineOption,
    ReportOption,
    adequacy_rule,
    command_line,
    coverage_from_options,
    emit_result,
    machine_with_parameters,
    user_errors,
)
from mtmetrology.cli._history import record_in_history
from mtmetrology.cli._progress import progress_bar
from mtmetrology.io.files import InputFileError, atomic_write, check_output

__all__ = ["app", "calibrate_ballplate", "gp_app"]


FILES_HELP = (
    "Files: PLATE (kind: ball-plate; balls: list of id, x_mm, y_mm, z_mm; u_mm or "
    "covariance_mm2). PROBES (kind: probe-set; probes: list of id, offset_mm: the stylus tip "
    "centre from the machine's reference point). RECORDS CSV position,ball,probe,X,Y,Z (mm): "
    "the readings that put the stylus tip centre at the ball centre. POSITIONS (kind: "
    "ballplate-positions; positions: list of id, origin_mm, rotation_deg, probes)."
)


def _help(func) -> str:
    return inspect.cleandoc(func.__doc__ or "") + "\n\n" + FILES_HELP


gp_app = typer.Typer(
    help="Gaussian-process error model of a CMM (fit on ball-plate records, predict).",
    no_args_is_help=True,
)

PlateOpt = Annotated[Path, typer.Option("--plate", help="Ball-plate file (kind: ball-plate).")]
ProbesOpt = Annotated[Path, typer.Option("--probes", help="Probe-set file (kind: probe-set).")]
SigmaOpt = Annotated[
    float,
    typer.Option("--sigma-um", help="Standard uncertainty of one reading coordinate, µm."),
]
OutOpt = Annotated[Path, typer.Option("-o", "--output", help="Output file.")]


def positive_option(value: float, name: str) -> float:
    """``value`` if it is a positive finite number, else an input error naming the option
    ``name`` (exit 2)."""
    if not (math.isfinite(value) and value > 0):
        raise InputFileError(f"{name}: must be a positive number, got {value}")
    return value


def cmm_report(ctx: typer.Context, title: str, inputs: list[Path], machine: str | None = None):
    """A report with the command line and the input files (and the machine) as provenance.

    Built before the JSON result is written, so that a failing renderer leaves nothing.
    """
    from mtmetrology.report import Report

    provenance: dict = {"inputs": inputs}
    if machine is not None:
        provenance["machine"] = machine
    return Report(title, command=command_line(ctx), provenance=provenance)


def add_cmm_result(report, result, **context) -> None:
    """Append ``result`` to ``report`` with the CMM renderers registered."""
    import mtmetrology.cmm.report  # noqa: F401  (registers the CMM renderers)
    from mtmetrology.report.results import add_result as add

    add(report, result, **context)


def read_ballplate_inputs(records: Path, plate: Path, probes: Path):
    """The ball-plate records read against their plate and probe-set files: (records,
    plate, probes)."""
    from mtmetrology.cmm.files import load_plate, load_probes, read_records

    pl, pr = load_plate(plate), load_probes(probes)
    return read_records(records, pl, pr), pl, pr


def calibrate_ballplate(
    ctx: typer.Context,
    records: Path,
    machine: str,
    plate: Path,
    probes: Path,
    output: Path,
    *,
    model: str,
    degrees: str | None,
    candidates: str,
    sigma_um: float,
    seed: int,
    keep_a_priori: bool,
    json_out: bool,
    report_path: Path | None,
    history: bool,
) -> None:
    """``mtm cmm calibrate`` without ``--qualification``: the styli by their probe-set
    offsets (:func:`mtmetrology.cmm.requests.calibrate_ballplate_files`)."""
    from mtmetrology.cmm.requests import calibrate_ballplate_files
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.units import to_internal

    sigma = to_internal(positive_option(sigma_um, "--sigma-um"), "µm")
    m = Machine.load(machine)
    with progress_bar("model selection fits") as progress:
        request = calibrate_ballplate_files(
            records,
            m,
            plate,
            probes,
            model=model,
            degrees=degrees,
            candidates=[c.strip() for c in candidates.split(",") if c.strip()],
            sigma=sigma,
            seed=seed,
            adequacy=adequacy_rule(keep_a_priori),
            progress=progress,
        )
    cal, selection = request.calibration, request.selection
    doc = request.to_dict()
    report = None
    if report_path is not None:
        report = cmm_report(
            ctx, f"Ball-plate calibration: {records.name}", [records, plate, probes], machine
        )
        add_cmm_result(report, cal, model_selection=selection)
    if history:
        record_in_history(doc, m, "mtm cmm calibrate", [records, plate, probes])

    def messages() -> None:
        if selection is not None:
            _print_selection(selection)
        u = cal.summary
        if not cal.identification.success:
            typer.echo(f"warning: {cal.identification.message}", err=True)
        adequacy = doc["adequacy"]
        if adequacy["significant"]:
            worst = max(doc["residual_patterns"]["probe"], key=lambda g: g["rms_weighted"])
            typer.echo(
                f"warning: {adequacy['message']}; largest residual rms at stylus "
                f"{worst['group']} ({worst['rms_µm']:.2g} µm); "
                + (
                    "compare models with --model auto"
                    if selection is None
                    else "no candidate explains them: give more --candidates (higher degrees) "
                    "or a larger --sigma-um"
                ),
                err=True,
            )
        typer.echo(
            f"{cal.model}: {cal.machine.n_params} parameters, rms residual "
            f"{doc['fit']['rms_residual_um']:.3g} µm; mean standard uncertainties (the "
            f"source's U1-U3) u1 {_rounded(u['U1_um'])} u2 {_rounded(u['U2_um'])} "
            f"u3 {_rounded(u['U3_um'])} µm; "
            f"wrote {output}",
            err=True,
        )

    emit_result(
        doc,
        None,
        output=output,
        report=report,
        report_path=report_path,
        as_json=json_out,
        messages=messages,
    )


def _rounded(values) -> str:
    """Standard uncertainties with two significant digits, ``[0.48, 0.78, 0.29]``."""
    from mtmetrology.formatting import format_uncertainty

    return "[" + ", ".join(format_uncertainty(float(v)) for v in values) + "]"


def _print_selection(selection: dict) -> None:
    """Every candidate's held-out scores, AIC and flags (standard error, like the summary)."""
    typer.echo(f"model selection: {selection['method']}", err=True)
    for s in selection["scores"]:
        if not s["full_rank"]:
            typer.echo(f"  {s['model']:<7} not identifiable from these records", err=True)
            continue
        per_position = ", ".join(
            f"{p} {'—' if v is None else f'{v:.3g}'}"
            for p, v in zip(selection["positions"], s["rms_um"], strict=True)
        )
        score = "not scored" if s["median_rms_um"] is None else f"{s['median_rms_um']:.3g} µm"
        flags = [
            f
            for f, on in (
                ("chosen", s["model"] == selection["chosen"]),
                (
                    f"identifiable in {s['identifiable_folds']} of {len(selection['folds'])} folds",
                    s["identifiable_folds"] < len(selection["folds"]),
                ),
            )
            if on
        ]
        typer.echo(
            f"  {s['model']:<7} held-out median {score}, AIC {s['aic']:.1f}, BIC "
            f"{s['bic']:.1f}"
            + (f" [{', '.join(flags)}]" if flags else "")
            + ("" if s["median_rms_um"] is None else f"; by position: {per_position}"),
            err=True,
        )


@user_errors
def budget_cmd(
    ctx: typer.Context,
    budget: Annotated[Path, typer.Argument(help="Budget inputs (kind: ballplate-budget).")],
    output: OutOpt,
    json_out: Annotated[bool, typer.Option("--json", help="Also print the result.")] = False,
    report_path: ReportOption = None,
    k: CoverageK = None,
    p: CoverageP = None,
) -> None:
    """Uncertainty budget of a ball-plate length (15 items, Edlén refractive index, GUF)."""
    from mtmetrology.cmm.budget import ballplate_budget_file
    from mtmetrology.formatting import format_coverage, format_result, format_uncertainty
    from mtmetrology.units import convert

    result = ballplate_budget_file(budget, coverage_from_options(k, p).p)
    doc = result.to_dict()
    report = None
    if report_path is not None:
        report = cmm_report(ctx, f"Ball-plate length budget: {budget.name}", [budget])
        add_cmm_result(report, result)

    def messages() -> None:
        o = doc["outputs"][0]
        u_um = float(convert(o["u"], o["unit"], "µm"))
        typer.echo(
            format_result(o["value"], u_um, "mm", name="l_x", u_unit="µm", k=o["k"], p=o["p"])
            + f"; wrote {output}",
            err=True,
        )
        if "statement" in doc:
            st = doc["statement"]
            typer.echo(
                f"at {st['length_mm']:g} mm ({format_coverage(st['k'])}): CMM U = "
                f"{format_uncertainty(st['U_cmm_um'])} µm, plate U = "
                f"{format_uncertainty(st['U_plate_um'])} µm, MPE {st['mpe_um']:.3g} µm; "
                f"U(P) = {format_uncertainty(st['U_P_um'])} µm, "
                f"U(E) = {format_uncertainty(st['U_E_um'])} µm",
                err=True,
            )

    emit_result(
        doc,
        None,
        output=output,
        report=report,
        report_path=report_path,
        as_json=json_out,
        messages=messages,
    )


@user_errors
def simulate_ballplate_cmd(
    machine: MachineOption,
    plate: PlateOpt,
    probes: ProbesOpt,
    positions: Annotated[
        Path, typer.Option("--positions", help="Plate positions (kind: ballplate-positions).")
    ],
    output: OutOpt,
    params: Annotated[
        Path | None, typer.Option("--params", help="True errors (parameter set); zero if omitted.")
    ] = None,
    sigma_um: Annotated[float, typer.Option("--sigma-um", help="Reading noise, µm.")] = 0.5,
    seed: Annotated[int, typer.Option("--seed", help="Random seed.")] = 0,
    exact_plate: Annotated[
        bool, typer.Option("--exact-plate", help="True plate = certificate (no draw).")
    ] = False,
) -> None:
    """Simulate ball-plate records (position,ball,probe,X,Y,Z) of a virtual CMM."""
    from mtmetrology.cmm.files import load_plate, load_positions, load_probes, write_records
    from mtmetrology.cmm.simulate import simulate_ballplate
    from mtmetrology.units import to_internal

    if not (math.isfinite(sigma_um) and sigma_um >= 0):
        raise InputFileError(f"--sigma-um: must be >= 0, got {sigma_um}")
    m, theta = machine_with_parameters(machine, params)
    pl, pr = load_plate(plate), load_probes(probes)
    pos = load_positions(positions, pr)
    camp = simulate_ballplate(
        m,
        theta,
        pl,
        pos,
        pr,
        sigma=to_internal(sigma_um, "µm"),
        seed=seed,
        perturb_plate=not exact_plate,
    )
    write_records(output, camp.records)
    typer.echo(f"wrote {len(camp.records)} records to {output}", err=True)


@gp_app.command("fit")
@user_errors
def gp_fit(
    ctx: typer.Context,
    records: Annotated[Path, typer.Argument(help="Records CSV: position,ball,probe,X,Y,Z (mm).")],
    machine: MachineOption,
    plate: PlateOpt,
    probes: ProbesOpt,
    output: OutOpt,
    mean: Annotated[
        str, typer.Option("--mean", help="Kinematic mean: seed, full-<d>, or none (zero mean).")
    ] = "seed",
    kernel: Annotated[str, typer.Option("--kernel", help="rbf (squared exp.) or matern.")] = "rbf",
    sigma_um: SigmaOpt = 0.5,
    seed: Annotated[int, typer.Option("--seed", help="Optimiser random state.")] = 0,
    report_path: ReportOption = None,
) -> None:
    """Fit a GP per error component (ML hyper-parameters), alternating with plate poses."""
    from mtmetrology.cmm.gp import fit_gp
    from mtmetrology.cmm.models import parse_model
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.units import to_internal

    sigma = to_internal(positive_option(sigma_um, "--sigma-um"), "µm")
    m = Machine.load(machine)
    rec, pl, pr = read_ballplate_inputs(records, plate, probes)
    if mean != "none":
        parse_model(mean)
    if kernel not in ("rbf", "matern"):
        raise InputFileError(f"--kernel {kernel!r}: use rbf or matern")
    gp = fit_gp(
        m,
        rec,
        pl,
        pr,
        sigma=sigma,
        mean=None if mean == "none" else mean,
        kernel=kernel,
        seed=seed,
    )
    doc = gp.to_document()
    report = None
    if report_path is not None:
        report = cmm_report(
            ctx, f"GP error model: {records.name}", [records, plate, probes], machine
        )
        add_cmm_result(report, gp)

    def messages() -> None:
        parts = ", ".join(
            f"{c['component']}: ℓ {c['length_scale_mm']:.0f} mm, s {c['amplitude_um']:.2g} µm, "
            f"noise {c['noise_um']:.2g} µm"
            for c in doc["components"]
        )
        typer.echo(f"{parts}; wrote {output}", err=True)
        for flag in gp.at_bounds:
            typer.echo(f"warning: hyper-parameter {flag} (not a likelihood optimum)", err=True)

    emit_result(
        doc,
        None,
        output=output,
        report=report,
        report_path=report_path,
        as_json=False,
        messages=messages,
    )


@gp_app.command("predict")
@user_errors
def gp_predict(
    readings: Annotated[Path, typer.Argument(help="CSV with X,Y,Z (mm) and probe columns.")],
    machine: MachineOption,
    model: Annotated[Path, typer.Option("--model", help="GP model file (mtm gp fit).")],
    probes: ProbesOpt,
    output: OutOpt,
) -> None:
    """Compensated x,y,z (mm) with standard uncertainties u_x_um,u_y_um,u_z_um (µm), the
    columns of ``mtm predict --u``."""
    from mtmetrology.cli.predict import U_COLUMNS
    from mtmetrology.cmm.files import load_probes, probe_tools
    from mtmetrology.cmm.gp import GPErrorModel
    from mtmetrology.io.documents import load_document
    from mtmetrology.io.tables import read_csv_table, write_columns
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.units import from_internal

    check_output(output, [readings, model, probes])
    m = Machine.load(machine)
    gp = GPErrorModel.from_document(load_document(model, "GP model"), m, str(model))
    table = read_csv_table(readings, required=["X", "Y", "Z", "probe"])
    q = table.vectors("XYZ")
    tools = probe_tools(load_probes(probes), table)
    pts, u = gp.predict(q, tools)
    u_um = from_internal(u, "µm")
    columns = {c: table.text.column(c) for c in table.header}
    columns.update({c: pts[:, k] for k, c in enumerate("xyz")})
    columns.update({c: u_um[:, k] for k, c in enumerate(U_COLUMNS)})
    with atomic_write(output, "wb") as fh:
        write_columns(fh, columns, decimals=6, plain=() if table.quoted else table.header)
    typer.echo(f"wrote {len(table)} rows to {output}", err=True)


#: The CMM commands of the ``mtm cmm`` group defined here (the studies and the
#: calibration are in :mod:`mtmetrology.cli.cmm_studies`).
app = typer.Typer()
app.command("simulate", help=_help(simulate_ballplate_cmd))(simulate_ballplate_cmd)
app.command("budget")(budget_cmd)
