"""``mtm samba calibrate`` and ``mtm samba unexplained``: a five-axis machine's errors from
SAMBA records (commands of the ``mtm samba`` group, :data:`mtmetrology.cli.SHARED_GROUPS`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Literal

import typer
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from mtmetrology.cli._common import (
    ArtefactOption,
    CoverageK,
    CoverageP,
    ErrorModelOption,
    KeepAPrioriOption,
    MachineOption,
    ParamsOnlyOption,
    ReportOption,
    adequacy_rule,
    command_line,
    coverage_from_options,
    emit_result,
    fail,
    user_errors,
)
from mtmetrology.cli._history import HistoryOption, record_in_history
from mtmetrology.cli._progress import progress_bar
from mtmetrology.errors import ConvergenceError, InputError
from mtmetrology.io.files import InputFileError, write_json

if TYPE_CHECKING:
    from mtmetrology.kinematics.machine import Machine

app = typer.Typer(help="Calibrate a machine from artefact measurements.", no_args_is_help=True)

CALIBRATE_HELP = """Identify a five-axis machine's geometric errors from a SAMBA test.

RECORDS.csv (mm, degrees) holds ball-centre indications (ball,X,Y,Z,B,C[,S]), raw
probed points (measurement,ball,X,Y,Z,B,C[,S,i,j,k]: one sphere fit per measurement)
or either form repeated K times (campaign,...: mean indications and their sample
covariance); optional sense_<axis> columns (+1/-1) feed reversal terms. ARTEFACT.yaml
names the balls, the scale bar and the stylus tip; REPEATABILITY.json the standard
uncertainty of a reading per axis. Formats: mtm formats samba-calibration.

RESULT.json (kind samba-calibration) is a parameter set that 'mtm predict --params'
reads as it is, plus the ball centres, tool vector, residuals, volumetric errors,
identifiability indices, sign conventions and, with --uncertainty, the GUF and Monte
Carlo outputs and their JCGM 102 validation. U = k u with one coverage factor in the
console, RESULT.json and the report: k = 2 (p = 95.45 % for a normal output, EA-4/02),
or --k / --p.

--tool-prior-um U (or UX,UY,UZ) with --estimate-tool: the tool vector is known to U µm
(standard uncertainty of each component) about the machine's nominal tool vector
(Alami Mchichi (2018): the tool length to 1 mm, --tool-prior-um 1000).

A rank-deficient test is refused, naming the confounded parameters and what to add;
--min-norm returns the minimum-norm solution instead, flagged in the result.

When the residuals contradict the model or the stated noise (chi-squared p < 0.01) the
output says so and the covariance (and the GUF/Monte Carlo inputs) is scaled by the
variance factor s², unless --keep-a-priori-covariance; RESULT.json records the test
(adequacy) and the residual RMS by ball and stylus (residual_patterns).
"""


class Repeatability(BaseModel):
    """Per-axis standard uncertainty of one indication reading (µm)."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
    kind: Literal["samba-repeatability"]
    version: Literal[1]
    u_um: dict[Literal["X", "Y", "Z"], float] = Field(min_length=3, max_length=3)


def load_repeatability(path: Path) -> tuple[float, float, float]:
    """(u_X, u_Y, u_Z) in mm from a repeatability JSON/YAML file."""
    from mtmetrology.io.documents import load_document
    from mtmetrology.io.schema import describe_validation_error
    from mtmetrology.units import to_internal

    data = load_document(path, "repeatability model")
    try:
        model = Repeatability.model_validate(data)
    except ValidationError as err:
        raise InputFileError(describe_validation_error(str(path), "repeatability", err)) from None
    u = tuple(float(to_internal(model.u_um[a], "µm")) for a in "XYZ")
    if min(u) <= 0:
        raise InputFileError(f"{path}: u_um: every standard uncertainty must be positive")
    return u


def parse_tool_prior(text: str | None, estimate_tool: bool) -> tuple[float, ...] | None:
    """Standard uncertainties (mm) of ``--tool-prior-um U`` or ``UX,UY,UZ`` (µm).

    Examples
    --------
    >>> parse_tool_prior("1000", True)
    (1.0,)
    >>> parse_tool_prior(None, False) is None
    True
    """
    from mtmetrology.units import to_internal

    if text is None:
        return None
    if not estimate_tool:
        raise InputError("--tool-prior-um needs --estimate-tool (the prior is on the tool vector)")
    parts = [t.strip() for t in text.split(",")]
    try:
        values = [float(t) for t in parts]
    except ValueError:
        raise InputError(f"--tool-prior-um: give U or UX,UY,UZ in µm, got {text!r}") from None
    if len(values) not in (1, 3):
        raise InputError(f"--tool-prior-um: give one value or three (x, y, z), got {text!r}")
    if not all(v > 0 and v < float("inf") for v in values):
        raise InputError(f"--tool-prior-um: every u must be positive and finite, got {text!r}")
    return tuple(float(to_internal(v, "µm")) for v in values)


def _machine(machine: str, model: str | None, params_only: str | None) -> Machine:
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.parameters import parse_parameter

    m = Machine.load(machine, model)
    if params_only:
        names = [parse_parameter(n.strip()).name for n in params_only.split(",") if n.strip()]
        if not names:
            raise InputError("--params-only: give parameter names separated by commas")
        m = m.with_parameters(names)
    if m.n_params == 0:
        raise InputError(f"{machine}: the error model has no parameters to identify")
    return m


def samba_report(ctx: typer.Context, title: str, inputs: list, result, **context):
    """A report of a SAMBA ``result`` with the command line and inputs as provenance.

    Built before the JSON result is written, so that a failing renderer leaves nothing.
    ``inputs`` are the input files (and a machine preset name); ``context`` goes to the
    renderer (:mod:`mtmetrology.samba.report`).
    """
    import mtmetrology.samba.report  # noqa: F401  (registers the SAMBA renderers)
    from mtmetrology.report import Report
    from mtmetrology.report.results import add_result

    files = [p for p in inputs if isinstance(p, Path)]
    names = [p for p in inputs if not isinstance(p, Path)]
    provenance: dict = {"inputs": files}
    if names:
        provenance["machine"] = ", ".join(names)
    seed = ctx.params.get("seed")
    if seed is not None:
        provenance["seed"] = seed
    report = Report(title, command=command_line(ctx), provenance=provenance)
    return add_result(report, result, **context)


@app.command("samba", help=CALIBRATE_HELP)
@user_errors
def samba(
    ctx: typer.Context,
    records: Annotated[
        Path, typer.Argument(help="RECORDS.csv (formats: mtm formats samba-calibration).")
    ],
    machine: MachineOption,
    artefact: ArtefactOption,
    model: ErrorModelOption = None,
    params_only: ParamsOnlyOption = None,
    noise_um: Annotated[
        float | None,
        typer.Option(
            "--noise-um",
            help="Standard uncertainty of every reading, µm [0.5]; with K campaigns, of each "
            "campaign's readings (their mean gets σ/√K).",
        ),
    ] = None,
    repeatability: Annotated[
        Path | None, typer.Option("--repeatability", help="REPEATABILITY.json (per-axis u).")
    ] = None,
    uncertainty: Annotated[
        str, typer.Option("--uncertainty", help="none, guf, mcm or both.")
    ] = "none",
    trials: Annotated[
        int | None, typer.Option("--trials", help="Monte Carlo trials (fixed) [100000].")
    ] = None,
    adaptive: Annotated[
        bool, typer.Option("--adaptive", help="Adaptive Monte Carlo (JCGM 101 §7.9).")
    ] = False,
    digits: Annotated[
        int,
        typer.Option("--digits", help="Significant digits of u for the tolerances δ [1]."),
    ] = 1,
    seed: Annotated[int | None, typer.Option("--seed", help="Random seed.")] = None,
    executor: Annotated[
        str | None,
        typer.Option("--executor", help="inprocess, processes[:n], dask-local[:n] or a scheduler."),
    ] = None,
    estimate_tool: Annotated[
        bool, typer.Option("--estimate-tool", help="Identify the tool vector too (needs S).")
    ] = False,
    tool_prior_um: Annotated[
        str | None,
        typer.Option(
            "--tool-prior-um",
            help="Prior u of each tool-vector component about the nominal, µm: U or UX,UY,UZ "
            "(with --estimate-tool).",
        ),
    ] = None,
    min_norm: Annotated[
        bool, typer.Option("--min-norm", help="Minimum-norm solution if rank deficient.")
    ] = False,
    keep_a_priori: KeepAPrioriOption = False,
    json: Annotated[bool, typer.Option("--json", help="Print RESULT.json.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="RESULT.json.")] = None,
    report_path: ReportOption = None,
    campaign_uncertainty: Annotated[
        Literal["mean", "single"],
        typer.Option(
            "--campaign-uncertainty",
            help="With K campaigns: u of their mean (S/K) or of one run (S, as Table 5-2 of "
            "Sepahi Boroujeni (2021)); needs --uncertainty with single.",
        ),
    ] = "mean",
    unexplained_out: Annotated[
        Path | None,
        typer.Option(
            "--unexplained-out",
            help="Write cov(e) of the residuals (E.json, for mtm task uncertainty --unexplained).",
        ),
    ] = None,
    history: HistoryOption = False,
    k: CoverageK = None,
    p: CoverageP = None,
) -> None:
    from mtmetrology.samba import (
        calibrate,
        evaluate_uncertainty,
        indication_inputs,
        load_artefact,
        read_records,
    )
    from mtmetrology.samba.uncertainty import pooled_sigma
    from mtmetrology.units import from_internal, to_internal

    if uncertainty not in ("none", "guf", "mcm", "both"):
        raise InputError(f"--uncertainty must be none, guf, mcm or both, got {uncertainty!r}")
    policy = coverage_from_options(k, p)
    if noise_um is not None and repeatability is not None:
        raise InputError("give --noise-um or --repeatability, not both")
    if noise_um is not None and not noise_um > 0:
        raise InputError(f"--noise-um must be positive, got {noise_um}")
    if trials is not None and adaptive:
        raise InputError("give --trials or --adaptive, not both")
    if campaign_uncertainty == "single" and uncertainty == "none":
        raise InputError("--campaign-uncertainty single needs --uncertainty guf, mcm or both")
    tool_prior = parse_tool_prior(tool_prior_um, estimate_tool)
    m = _machine(machine, model, params_only)
    art = load_artefact(artefact)
    rec = read_records(records, m, art)
    noise = repeat = campaigns = None
    if repeatability is not None:
        repeat = load_repeatability(repeatability)
        described = f"repeatability model {repeatability}"
        if rec.campaigns is not None:
            # the indications are means of K campaigns: u of a mean is u/√K
            repeat = tuple(u / rec.n_campaigns**0.5 for u in repeat)
            described += f", of the mean of {rec.n_campaigns} campaigns (/√{rec.n_campaigns})"
        sigma = float(sum(u * u for u in repeat) / 3) ** 0.5
    elif noise_um is None and rec.campaigns is not None:
        campaigns = rec.campaigns
        # the indications are means of K campaigns: weighted with σ̄/√K
        sigma = pooled_sigma(campaigns) / rec.n_campaigns**0.5
        described = f"sample covariance of {rec.n_campaigns} campaigns" + (
            f" / {rec.n_campaigns} (their mean)" if campaign_uncertainty == "mean" else " (one run)"
        )
    else:
        noise = float(to_internal(0.5 if noise_um is None else noise_um, "µm"))
        described = f"probing noise {from_internal(noise, 'µm'):g} µm per reading"
        if rec.campaigns is not None:
            # the indications are means of K campaigns: u of a mean is σ/√K
            noise /= rec.n_campaigns**0.5
            described += f", of the mean of {rec.n_campaigns} campaigns (/√{rec.n_campaigns})"
        sigma = noise
    try:
        cal = calibrate(
            m,
            rec,
            art,
            sigma=sigma,
            estimate_tool=estimate_tool,
            tool_prior=tool_prior,
            minimum_norm=min_norm,
            adequacy=adequacy_rule(keep_a_priori),
        )
    except ConvergenceError as err:
        fail(str(err))
    unc = None
    if uncertainty != "none":
        inputs = indication_inputs(
            cal.problem,
            noise=noise,
            repeatability=repeat,
            campaigns=campaigns,
            campaign_mean=campaign_uncertainty == "mean",
        )
        try:
            with progress_bar("Monte Carlo trials") as progress:
                unc = evaluate_uncertainty(
                    cal,
                    inputs,
                    described,
                    method=uncertainty,
                    trials=trials,
                    adaptive=adaptive,
                    digits=digits,
                    seed=seed,
                    executor=executor,
                    p=policy.p,
                    progress=progress,
                )
        except ConvergenceError as err:
            fail(str(err))
    doc = cal.to_dict(unc, described, policy)
    if campaigns is not None:
        doc["records"]["uncertainty_of"] = (
            f"mean of {rec.n_campaigns} campaigns" if campaign_uncertainty == "mean" else "one run"
        )
    report = None
    if report_path is not None:
        inputs = [records, artefact, machine if not Path(machine).is_file() else Path(machine)]
        if repeatability is not None:
            inputs.append(repeatability)
        report = samba_report(
            ctx, f"SAMBA calibration: {records.name}", inputs, cal, uncertainty=unc, policy=policy
        )
    cov_e = None if unexplained_out is None else unexplained_from_calibration(cal, sigma)
    if history:
        record_in_history(doc, m, "mtm samba calibrate", [records, artefact])
    if cov_e is not None:
        write_json(unexplained_out, cov_e.to_dict())

    def summary() -> None:
        _summary(doc, output)
        if cov_e is not None:
            u = from_internal(cov_e.u, "µm")
            typer.echo(
                f"unexplained volumetric error u(e) = {u[0]:.2g}, {u[1]:.2g}, {u[2]:.2g} µm "
                f"(ν = {cov_e.degrees_of_freedom:.1f}) → {unexplained_out}"
            )

    emit_result(doc, summary, output=output, report=report, report_path=report_path, as_json=json)


def unexplained_from_calibration(cal, sigma: float):
    """cov(e) of a SAMBA calibration's residual vectors: p = all unknowns fitted (machine
    parameters, ball centres, tool), Σ_v = σ² I the indication noise it was weighted with
    (:mod:`mtmetrology.uncertainty.unexplained_estimate`)."""
    from mtmetrology.uncertainty.unexplained_estimate import estimate_unexplained_covariance

    return estimate_unexplained_covariance(
        cal.residual_vectors,
        fitted_parameters=len(cal.identification.estimate),
        noise_covariance=sigma**2,
        source=f"SAMBA residuals of {cal.records.source} ({len(cal.records)} indications)",
    )


def _parameter_line(p: dict, k: float) -> str:
    """``E_A0B  -9.6 µrad  u = 1.8 µrad  U = 3.7 µrad (k = 2)``: u and U with two
    significant digits, the value to the same decimal (JCGM 100:2008, 7.2.6)."""
    from mtmetrology.formatting import format_k, format_uncertainty, format_value

    u, unit = p.get("u"), p["unit"]
    if u is None:
        return f"{p['name']:<8} {format_value(p['value']):>12} {unit}  (no uncertainty)"
    return (
        f"{p['name']:<8} {format_value(p['value'], u):>12} {unit:<4}  "
        f"u = {format_uncertainty(u)} {unit}  U = {format_uncertainty(k * u)} {unit} "
        f"(k = {format_k(k)})"
    )


def _propagation_factors(factors: list[dict]) -> None:
    """UPF = u/σ of each parameter (Alami Mchichi (2018) eq. 6.14), four to a line: u
    includes the scale bar's u, so it is u over σ, not a sensitivity to σ alone (for a
    scale parameter such as E_XX1 the bar dominates)."""
    from mtmetrology.formatting import format_uncertainty

    cells = [f"{f['name']} {format_uncertainty(f['upf'])} {f['upf_unit']}" for f in factors]
    if not cells or factors[0]["upf"] is None:
        return
    typer.echo("UPF = u/σ: each parameter's u (probing noise and scale-bar u) over the σ in µm:")
    for i in range(0, len(cells), 4):
        typer.echo("  " + ";  ".join(cells[i : i + 4]))


def _summary(doc: dict, output: Path | None) -> None:
    ident = doc["identification"]
    typer.echo(f"SAMBA calibration: {ident['message']}")
    if ident["minimum_norm"]:
        typer.echo("WARNING: minimum-norm solution of a rank-deficient problem", err=True)
    from mtmetrology.formatting import format_coverage

    cov = doc["coverage"]
    typer.echo(
        "parameters: value, standard uncertainty u, expanded uncertainty U = k u "
        f"({format_coverage(cov['k'], cov['coverage_probability'])})"
    )
    for p in doc["parameters"]:
        typer.echo("  " + _parameter_line(p, cov["k"]))
    _propagation_factors(doc["propagation_factors"])
    v = doc["volumetric_error"]
    typer.echo(
        "volumetric error norm: unexplained mean {:.3f} max {:.3f} µm; nominal model mean "
        "{:.3f} max {:.3f} µm".format(
            v["unexplained"]["mean_um"],
            v["unexplained"]["max_um"],
            v["nominal_model"]["mean_um"],
            v["nominal_model"]["max_um"],
        )
    )
    typer.echo(f"model adequacy: {doc['adequacy']['message']}")
    if doc["adequacy"]["significant"]:
        worst = max(doc["residual_patterns"]["ball"], key=lambda g: g["rms_weighted"])
        typer.echo(
            f"  largest residual rms at ball {worst['group']}: {worst['rms_µm']:.2g} µm "
            f"({worst['rms_weighted']:.2g} × the stated noise)"
        )
    mc = doc.get("uncertainty", {}).get("mcm")
    if mc is not None:
        run = "adaptive, " + ("converged" if mc["converged"] else "not converged")
        typer.echo(
            f"Monte Carlo: {mc['trials']} trials in {mc['sequences']} sequence"
            + ("s" if mc["sequences"] > 1 else "")
            + (f" ({run})" if mc["adaptive"] else "")
        )
    if "uncertainty" in doc and "validation" in doc["uncertainty"]:
        typer.echo(doc["uncertainty"]["validation"]["message"])
    if output is not None:
        typer.echo(f"wrote {output}", err=True)


UNEXPLAINED_HELP = """cov(e) of the unexplained volumetric error from repeated SAMBA campaigns.

CAMPAIGN.csv ...: two or more records files of the same SAMBA test (same balls,
indexations and styli in the same order; any form 'mtm samba calibrate' reads), each
calibrated on its own. The estimate is the scatter of the residual field between the
campaigns at the common positions, less the probing noise σ² (--noise-um), with
ν = (K − 1)(n − p/3), made positive semidefinite by eigenvalue clipping; the pooled
within-campaign estimate is given beside it. E.json is the unexplained-volumetric-error
document (µm²) that 'mtm task uncertainty --unexplained' reads, the same form as
'mtm samba calibrate --unexplained-out'.
"""


@app.command("unexplained", help=UNEXPLAINED_HELP)
@user_errors
def unexplained(
    ctx: typer.Context,
    campaigns: Annotated[
        list[Path], typer.Argument(help="CAMPAIGN.csv files (two or more, the same test).")
    ],
    machine: MachineOption,
    artefact: ArtefactOption,
    model: ErrorModelOption = None,
    params_only: ParamsOnlyOption = None,
    noise_um: Annotated[
        float, typer.Option("--noise-um", help="Standard uncertainty of every reading, µm.")
    ] = 0.5,
    estimate_tool: Annotated[
        bool, typer.Option("--estimate-tool", help="Identify the tool vector too (needs S).")
    ] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="E.json to write.")] = None,
    json: Annotated[bool, typer.Option("--json", help="Print E.json.")] = False,
    report_path: ReportOption = None,
) -> None:
    from mtmetrology.io.plausibility import distinct_files
    from mtmetrology.samba import load_artefact, read_records, unexplained_from_campaigns
    from mtmetrology.units import from_internal, to_internal

    if not noise_um > 0:
        raise InputError(f"--noise-um must be positive, got {noise_um}")
    m = _machine(machine, model, params_only)
    distinct_files(campaigns, "campaign records")
    art = load_artefact(artefact)
    records = [read_records(path, m, art) for path in campaigns]
    sigma = float(to_internal(noise_um, "µm"))
    result = unexplained_from_campaigns(m, records, art, sigma=sigma, estimate_tool=estimate_tool)
    report = None
    if report_path is not None:
        inputs = [*campaigns, artefact, machine if not Path(machine).is_file() else Path(machine)]
        report = samba_report(ctx, "cov(e) from SAMBA campaigns", inputs, result)

    def summary() -> None:
        for name, est in (
            ("between campaigns", result.between),
            ("within campaigns", result.within),
        ):
            u = from_internal(est.u, "µm")
            typer.echo(
                f"u(e) {name}: {u[0]:.2g}, {u[1]:.2g}, {u[2]:.2g} µm "
                f"(ν = {est.degrees_of_freedom:.1f}{', clipped' if est.clipped else ''})"
            )

    emit_result(
        result.to_dict(),
        summary,
        output=output,
        report=report,
        report_path=report_path,
        as_json=json,
    )
