"""``mtm budget``: task-uncertainty budgets (ISO 15530-3, VDI/VDE 2617-11 with a map)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from mtmetrology.budgets.choices import FEATURE_KINDS, Policy, RepeatabilityMethod
from mtmetrology.cli._common import (
    CoverageK,
    CoverageP,
    MachineOption,
    ReportOption,
    command_line,
    coverage_from_options,
    emit_result,
    user_errors,
)
from mtmetrology.errors import InputError

app = typer.Typer(help="Task-uncertainty budgets of on-machine measurements.", no_args_is_help=True)

ISO_HELP = """ISO 15530-3 budget of one characteristic from repeated cycles.

RUNS.csv: value[,series], one row per measurement cycle on the calibrated workpiece (mm);
series labels the series.  b = mean − VALUE.  Uncertainties in µm.  --policy 2004:
U = k·√(u_cal²+u_p²+u_w²) + |b|; 2011: b corrected, U = k·√(u_cal²+u_p²+u_b²+u_w²);
paper003 (default): u_b = |b| inside the root.  The probe error enters in quadrature
above 1 µm (small machine) or 3 µm (large).

Every policy and --u-p method needs the standard's 20 repeats in series of at least 10
cycles; --allow-few-repeats proceeds with fewer, says so and records
the deviation in the result.  Repeats, part readings and VALUE must all be in mm.

--part READINGS.csv (value, mm): a production part measured the same way; its result
(y − b under 2011, y otherwise) ± U, and with --tolerance the ISO 14253-1 decision on it.

u_w from its inputs instead of --u-w: --alpha and --alpha-half-width (µm/(m·K)),
--temperature (°C) and --u-temperature (K), --length (mm, default |VALUE|), --form (µm,
peak to valley): u_w = √(L²·[(T − 20 °C)²·u_α² + α²·u_T² + u_α²·u_T²] + F²/12),
u_α = a_α/√3 (ISO 15530-3, clause 7).
"""


def _report(ctx: typer.Context, title: str, inputs: list, header: list, rows: list, notes: str):
    from mtmetrology.report import Report

    report = Report(title, command=command_line(ctx), provenance={"inputs": inputs})
    report.section("Budget", notes)
    report.table(header, rows, caption="Standard uncertainties and U in µm.")
    return report


def _um(value: float, option: str) -> float:
    from mtmetrology.units import to_internal

    if not value >= 0:
        raise InputError(f"{option}: must be >= 0 µm, got {value}")
    return float(to_internal(value, "µm"))


def _workpiece(alpha, half_width, temperature, u_temperature, length, form):
    """The u_w inputs of the options, or None when none is given."""
    given = (alpha, half_width, temperature, u_temperature, length, form)
    if all(v is None for v in given):
        return None
    from mtmetrology.budgets.workpiece import WorkpieceVariation
    from mtmetrology.units import to_internal

    def per_kelvin(value):  # µm/(m·K): the ratio µm/m per kelvin
        return 0.0 if value is None else float(to_internal(value, "µm/m"))

    return WorkpieceVariation(
        length=length,
        alpha=per_kelvin(alpha),
        alpha_half_width=per_kelvin(half_width),
        temperature=temperature,
        u_temperature=0.0 if u_temperature is None else u_temperature,
        form=0.0 if form is None else _um(form, "--form"),
    )


def _iso_lines(budget, doc: dict) -> list[str]:
    """The console and report lines of the part, the u_w inputs and the decision."""
    from mtmetrology.formatting import format_result, format_uncertainty, format_value
    from mtmetrology.units import to_internal

    u_mm = float(to_internal(doc["um"]["u"], "µm"))

    lines = []
    if budget.workpiece is not None:
        w = doc["workpiece"]
        terms = ", ".join(f"{n} {format_uncertainty(v)}" for n, v in w["um"].items())
        lines.append(f"u_w from inputs (µm): {terms}; {w['formula']}")
    if budget.part is not None:
        part = budget.part
        how = "y − b" if part.bias_corrected else "y, b not corrected"
        lines.append(
            f"production part {part.name}: {part.n} reading(s), mean "
            f"{format_value(part.mean, u_mm)} mm, result "
            f"({how}) " + format_result(part.result, doc["um"]["u"], "mm", u_unit="µm", k=budget.k)
        )
        if part.decision is not None:
            lines.append(f"decision (ISO 14253-1) on {part.name}: {part.decision.decision}")
    elif budget.decision is not None:
        lines.append(
            f"decision (ISO 14253-1) on the reference workpiece's result: "
            f"{budget.decision.decision} (--part judges a production part)"
        )
    return lines


@app.command("iso15530-3", help=ISO_HELP)
@user_errors
def iso15530_3(
    ctx: typer.Context,
    runs: Annotated[Path, typer.Argument(help="RUNS.csv: value[,series] (mm).")],
    calibrated: Annotated[float, typer.Option("--calibrated", help="Calibrated value x_cal (mm).")],
    u_cal: Annotated[float, typer.Option("--u-cal", help="u_cal of x_cal (µm).")],
    u_w: Annotated[float, typer.Option("--u-w", help="Workpiece variation u_w (µm).")] = 0.0,
    u_b: Annotated[
        float, typer.Option("--u-b", help="Uncertainty of b, policy 2011 only (µm).")
    ] = 0.0,
    policy: Annotated[Policy, typer.Option("--policy", help="Combination rule.")] = (
        Policy.PAPER_003
    ),
    u_p_method: Annotated[
        RepeatabilityMethod, typer.Option("--u-p", help="u_p: sample s or max over series.")
    ] = RepeatabilityMethod.SAMPLE,
    allow_few_repeats: Annotated[
        bool,
        typer.Option(
            "--allow-few-repeats",
            help="Proceed with fewer than 20 repeats / 10 cycles a series; recorded.",
        ),
    ] = False,
    probe_u: Annotated[float, typer.Option("--probe-u", help="Probe systematic error (µm).")] = 0.0,
    machine_class: Annotated[
        str, typer.Option("--machine-class", help="small (1 µm) or large (3 µm) probe threshold.")
    ] = "small",
    k: CoverageK = None,
    p: CoverageP = None,
    part: Annotated[
        Path | None,
        typer.Option("--part", help="READINGS.csv: value (mm) of a production part."),
    ] = None,
    tolerance: Annotated[
        str | None,
        typer.Option("--tolerance", help="NOMINAL,LOWER,UPPER (mm): ISO 14253-1 decision."),
    ] = None,
    alpha: Annotated[
        float | None, typer.Option("--alpha", help="u_w: expansion coefficient α (µm/(m·K)).")
    ] = None,
    alpha_half_width: Annotated[
        float | None,
        typer.Option("--alpha-half-width", help="u_w: half-width of α between parts (µm/(m·K))."),
    ] = None,
    temperature: Annotated[
        float | None, typer.Option("--temperature", help="u_w: part temperature T (°C).")
    ] = None,
    u_temperature: Annotated[
        float | None, typer.Option("--u-temperature", help="u_w: standard uncertainty of T (K).")
    ] = None,
    length: Annotated[
        float | None, typer.Option("--length", help="u_w: length L (mm), default |x_cal|.")
    ] = None,
    form: Annotated[
        float | None, typer.Option("--form", help="u_w: form deviation F, peak to valley (µm).")
    ] = None,
    json: Annotated[bool, typer.Option("--json", help="Print the JSON document.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="JSON file.")] = None,
    report_path: ReportOption = None,
) -> None:
    from mtmetrology.budgets.iso15530 import iso15530_3_budget
    from mtmetrology.formatting import (
        format_coverage,
        format_uncertainty,
        format_value,
    )
    from mtmetrology.io import check_output, read_csv_table
    from mtmetrology.uncertainty.conformity import Tolerance
    from mtmetrology.units import to_internal

    inputs = [runs] if part is None else [runs, part]
    for target in (output, report_path):
        if target is not None:
            check_output(target, inputs)
    tol = None if tolerance is None else Tolerance.parse(tolerance)
    workpiece = _workpiece(alpha, alpha_half_width, temperature, u_temperature, length, form)
    table = read_csv_table(runs, required=["value"])
    series = table.strings("series") if table.has("series") else None
    readings = None if part is None else read_csv_table(part, required=["value"]).floats("value")
    budget = iso15530_3_budget(
        table.floats("value"),
        calibrated=calibrated,
        u_cal=_um(u_cal, "--u-cal"),
        u_w=_um(u_w, "--u-w"),
        u_b=_um(u_b, "--u-b"),
        series=series,
        policy=policy,
        repeatability_method=u_p_method,
        probe_error=_um(probe_u, "--probe-u"),
        machine_class=machine_class,
        k=coverage_from_options(k, p).k,
        tolerance=tol,
        name=str(runs),
        provenance={"runs": str(runs)} | ({} if part is None else {"part": str(part)}),
        allow_few_repeats=allow_few_repeats,
        part=readings,
        part_name="part" if part is None else part.name,
        workpiece=workpiece,
    )
    doc = budget.to_dict()
    u_mm = float(to_internal(doc["um"]["u"], "µm"))
    extra = _iso_lines(budget, doc)
    report = None
    if report_path is not None:
        um = doc["um"]
        names = ("b", "u_b", "u_p", "u_cal", "u_w", "u_probe", "u", "U")
        report = _report(
            ctx,
            f"ISO 15530-3 budget: {runs.name}",
            inputs,
            ["quantity", "µm"],
            [[n, um[n]] for n in names],
            f"Policy {budget.policy.value}, n = {budget.n}, {format_coverage(budget.k)}; mean "
            f"{format_value(budget.mean, u_mm)} mm, calibrated "
            f"{format_value(budget.calibrated, u_mm)} mm, "
            + _result_line(budget, um)
            + ". "
            + " ".join(f"{line}." for line in extra)
            + "".join(f" Deviation from ISO 15530-3: {d}." for d in budget.deviations),
        )

    def summary() -> None:
        um = doc["um"]
        typer.echo(
            f"ISO 15530-3 budget of {runs.name}, policy {budget.policy.value}, "
            f"n = {budget.n}, {format_coverage(budget.k)} (µm)"
        )
        typer.echo(
            f"  mean {format_value(budget.mean, u_mm)} mm  calibrated "
            f"{format_value(budget.calibrated, u_mm)} mm  b {format_value(um['b'], um['u_b'])}"
        )
        for name in ("u_b", "u_p", "u_cal", "u_w", "u_probe", "u", "U"):
            typer.echo(f"  {name:<8} {format_uncertainty(um[name])}")
        typer.echo("  " + _result_line(budget, um))
        for line in extra:
            typer.echo(f"  {line}")

    def messages() -> None:
        for deviation in budget.deviations:
            typer.echo(f"warning: deviation from ISO 15530-3 (recorded): {deviation}", err=True)

    emit_result(
        doc,
        summary,
        output=output,
        report=report,
        report_path=report_path,
        as_json=json,
        messages=messages,
    )


MAP_HELP = f"""VDI/VDE 2617-11 budget of a feature with a volumetric error map.

POINTS.csv: x,y,z[,cycle[,series]] (mm): the indicated contact (stylus-centre) points
of the feature, every cycle the same points.  --params: the machine's map, a parameter
set with covariance (MAP.json of 'mtm multilateration calibrate') or a volumetric-map
document.  Each point is corrected P_true = P - e(P); the feature ({", ".join(FEATURE_KINDS)})
is fitted to the original and corrected points; b = F(corrected) - F(original), u_b = |b|
(--mode uncorrected, the default) or the corrected value with u_b from the map covariance
(--mode corrected); u_p: the spread over the cycles, or of --repeats RUNS.csv
(characteristic,value[,series]: e.g. the on-machine software's results), or --u-p-um; u_cal: the map
covariance propagated to F (--u-cal guf, or mc with --trials); u_MS and U_MS = k u_MS.
Prints the budget in the layout of Mutilba et al., Table 1 (µm).
"""


@app.command("volumetric-map", help=MAP_HELP)
@user_errors
def volumetric_map(
    ctx: typer.Context,
    points: Annotated[Path, typer.Argument(help="POINTS.csv: x,y,z[,cycle[,series]] (mm).")],
    machine: MachineOption,
    params: Annotated[Path, typer.Option("--params", help="MAP.json or a map document.")],
    feature: Annotated[str, typer.Option("--feature", help=" | ".join(FEATURE_KINDS))],
    mode: Annotated[str, typer.Option("--mode", help="uncorrected or corrected.")] = (
        "uncorrected"
    ),
    u_p_um: Annotated[
        float | None, typer.Option("--u-p-um", help="u_p (µm) instead of the cycles'.")
    ] = None,
    repeats: Annotated[
        Path | None,
        typer.Option("--repeats", help="RUNS.csv: characteristic,value[,series] (mm)."),
    ] = None,
    u_p_method: Annotated[
        RepeatabilityMethod, typer.Option("--u-p", help="u_p: sample s or max over series.")
    ] = RepeatabilityMethod.SAMPLE,
    u_cal: Annotated[str, typer.Option("--u-cal", help="guf or mc.")] = "guf",
    trials: Annotated[int, typer.Option("--trials", help="Map draws of --u-cal mc.")] = 2000,
    seed: Annotated[int | None, typer.Option("--seed", help="Seed of --u-cal mc.")] = None,
    probe_u: Annotated[float, typer.Option("--probe-u", help="Probe systematic error (µm).")] = 0.0,
    machine_class: Annotated[
        str, typer.Option("--machine-class", help="small (1 µm) or large (3 µm) probe threshold.")
    ] = "small",
    k: CoverageK = None,
    p: CoverageP = None,
    outer: Annotated[
        bool, typer.Option("--outer", help="A shaft or ball (sizes probed from outside).")
    ] = False,
    tip_diameter: Annotated[
        float, typer.Option("--tip-diameter", help="Effective tip diameter (mm).")
    ] = 0.0,
    tolerance: Annotated[
        list[str] | None,
        typer.Option(
            "--tolerance",
            help="NAME=NOMINAL,LOWER,UPPER (mm), e.g. diameter=108,0,0.02; repeat.",
        ),
    ] = None,
    json: Annotated[bool, typer.Option("--json", help="Print the JSON document.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="JSON file.")] = None,
    report_path: ReportOption = None,
) -> None:
    from mtmetrology.budgets.volumetric_map import load_map, volumetric_map_budget
    from mtmetrology.io import check_output, read_csv_table
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.uncertainty.conformity import Tolerance

    for target in (output, report_path):
        if target is not None:
            check_output(target, [points, params])
    tolerances = {}
    for text in tolerance or []:
        name, sep, spec = text.partition("=")
        if not sep:
            raise InputError(f"--tolerance: expected NAME=NOMINAL,LOWER,UPPER, got {text!r}")
        tolerances[name.strip()] = Tolerance.parse(spec, parameter=f"--tolerance {name.strip()}")
    if trials < 2:
        raise InputError(f"--trials must be at least 2, got {trials}")
    k = coverage_from_options(k, p).k
    m = Machine.load(machine)
    table = read_csv_table(points, required=["x", "y", "z"])
    xyz = table.vectors("xyz")
    vmap = load_map(m, params, xyz, lambda i: f"{points}, line {table.lines[i]}")
    runs = None
    if repeats is not None:
        r = read_csv_table(repeats, required=["characteristic", "value"], min_rows=2)
        runs = (
            r.strings("characteristic"),
            r.floats("value"),
            r.strings("series") if r.has("series") else None,
        )
    budget = volumetric_map_budget(
        xyz,
        vmap,
        feature,
        cycles=table.strings("cycle") if table.has("cycle") else None,
        series=table.strings("series") if table.has("series") else None,
        machine=m.name,
        mode=mode,
        repeatability_method=u_p_method,
        u_p=None if u_p_um is None else _um(u_p_um, "--u-p-um"),
        repeats=runs,
        u_cal_method=u_cal,
        trials=trials,
        seed=seed,
        probe_error=_um(probe_u, "--probe-u"),
        machine_class=machine_class,
        k=k,
        inner=not outer,
        tip_diameter=tip_diameter,
        tolerances=tolerances,
        provenance={"points": str(points), "params": str(params)},
    )
    doc = budget.to_dict()
    report = None
    if report_path is not None:
        decisions = budget.decisions()
        report = _report(
            ctx,
            f"VDI/VDE 2617-11 budget with a volumetric map: {points.name}",
            [points, params],
            ["characteristic", "u_b", "u_p", "u_cal", "u_MS", "U_MS", "decision"],
            [
                [*row, decisions[row[0]].decision.value if row[0] in decisions else None]
                for row in budget.table()
            ],
            f"{feature}, {budget.cycles} cycle(s) of {budget.n_points} points, mode {mode} "
            f"(P_true = P - e(P)), u_cal by {u_cal}, k = {k:.3g}; largest map correction "
            f"{doc['largest_correction_um']:.2f} µm.",
        )

    def summary() -> None:
        typer.echo(
            f"VDI/VDE 2617-11 budget of {points.name}: {feature}, {budget.cycles} cycle(s) of "
            f"{budget.n_points} points, mode {mode}, u_cal by {u_cal}, k = {k:.3g} (µm); largest "
            f"map correction {doc['largest_correction_um']:.2f} µm"
        )
        typer.echo(
            f"  {'characteristic':<14} {'u_b':>6} {'u_p':>6} {'u_cal':>6} {'u_MS':>6} {'U_MS':>6}"
        )
        for row in budget.table():
            typer.echo(f"  {row[0]:<14} " + " ".join(f"{v:>6}" for v in row[1:]))
        for name, decision in budget.decisions().items():
            typer.echo(f"  decision (ISO 14253-1) on {name}: {decision.decision.value}")

    emit_result(doc, summary, output=output, report=report, report_path=report_path, as_json=json)


def _result_line(budget, um: dict) -> str:
    """``result = …, u = …, U = … (k = 2)``; under the 2004 policy U = k·u + |b| (the bias
    is not corrected), which the line says instead of implying U = k·u."""
    from mtmetrology.budgets.choices import Policy
    from mtmetrology.formatting import format_coverage, format_result, format_uncertainty

    if budget.policy is not Policy.ISO_2004:
        return format_result(budget.result, um["u"], "mm", name="result", u_unit="µm", k=budget.k)
    head = format_result(budget.result, um["U"], "mm", name="result", u_unit="µm")
    head = head.rsplit(", u = ", 1)[0]
    return (
        f"{head}, u = {format_uncertainty(um['u'])} µm, U = {format_uncertainty(um['U'])} µm "
        f"(k·u + |b|, {format_coverage(budget.k)})"
    )
