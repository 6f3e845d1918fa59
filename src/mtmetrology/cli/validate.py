"""``mtm task validate`` and ``mtm task validate-pooling``: validation campaigns of a task
uncertainty on calibrated artefacts.

Every side-A × side-B bipoint is compensated and given y ± U (full-covariance GUF); the
calibrated length is carried to the measurement temperature (eqs. 6-17, 6-19) and the
mean of eq. 6-16 is the delivered coverage, with the ablation without cov(e)
(Sepahi Boroujeni (2021), §6.4–6.5; library: :func:`mtmetrology.omm.validation.
validate_gauge`). The pooling test (§6.5) mixes k of several sphere point sets and
draws 25 points (:func:`mtmetrology.omm.pooling.pooling_experiment`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from mtmetrology.cli._common import (
    MachineOption,
    ReportOption,
    command_line,
    emit_result,
    user_errors,
)
from mtmetrology.cli._progress import progress_bar
from mtmetrology.errors import InputError

app = typer.Typer(help="Validate uncertainty statements against calibrated artefacts.")

CteOpt = Annotated[float, typer.Option("--cte", help="Expansion coefficient α, 1/°C.")]
CteUOpt = Annotated[float, typer.Option("--cte-u", help="u(α), 1/°C.")]
DeltaTUOpt = Annotated[float, typer.Option("--delta-t-u", help="u(ΔT), °C.")]
RepeatabilityOpt = Annotated[
    Path | None, typer.Option(help="repeatability-model JSON (needs i,j,k columns).")
]
UnexplainedOpt = Annotated[
    Path | None, typer.Option(help="unexplained-volumetric-error document (µm²).")
]
TipDiameterOpt = Annotated[
    float | None, typer.Option(help="Effective tip diameter, mm (default: the machine's).")
]


@app.callback()
def _group() -> None:
    """Validate uncertainty statements against calibrated artefacts."""


@app.command("task")
@user_errors
def task(
    ctx: typer.Context,
    side_a: Annotated[Path, typer.Argument(help="Side-A readings: point,X,Y,Z,B,C[,i,j,k].")],
    side_b: Annotated[Path, typer.Argument(help="Side-B readings, same columns.")],
    machine_name: MachineOption,
    params: Annotated[
        Path, typer.Option("--params", help="The calibration that compensates, with U_θ.")
    ],
    reference_mm: Annotated[
        float, typer.Option("--reference-mm", help="Calibrated length at 20 °C, mm.")
    ],
    reference_u_um: Annotated[
        float,
        typer.Option("--reference-u-um", help="Its standard uncertainty at 20 °C, µm (U/k)."),
    ],
    cte: CteOpt = 0.0,
    cte_u: CteUOpt = 0.0,
    delta_t: Annotated[
        float, typer.Option("--delta-t", help="Gauge temperature − 20 °C during probing.")
    ] = 0.0,
    delta_t_u: DeltaTUOpt = 0.0,
    long_term: Annotated[
        Path | None,
        typer.Option("--long-term", help="Parameter set whose covariance is Σ_lt."),
    ] = None,
    recalibrated: Annotated[
        bool, typer.Option("--recalibrated", help="Recalibrated for the campaign: no Σ_lt.")
    ] = False,
    repeatability: RepeatabilityOpt = None,
    unexplained: UnexplainedOpt = None,
    tip_diameter: TipDiameterOpt = None,
    p: Annotated[float, typer.Option("--p", help="Coverage probability.")] = 0.95,
    json_output: Annotated[bool, typer.Option("--json", help="Print the result document.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write it here.")] = None,
    report_path: ReportOption = None,
) -> None:
    """Coverage of gauge-length intervals over every side-A × side-B bipoint (eq. 6-16)."""
    from mtmetrology.omm.validation_request import validate_gauge_from_files
    from mtmetrology.units import to_internal

    result = validate_gauge_from_files(
        side_a,
        side_b,
        machine_name,
        params,
        reference_mm,
        float(to_internal(reference_u_um, "µm")),
        expansion_coefficient=cte,
        expansion_coefficient_uncertainty=cte_u,
        temperature_difference=delta_t,
        temperature_difference_uncertainty=delta_t_u,
        long_term=long_term,
        recalibrated=recalibrated,
        repeatability=repeatability,
        unexplained=unexplained,
        tip_diameter=tip_diameter,
        p=p,
    )
    doc = result.to_dict()
    report = None
    if report_path is not None:
        inputs = [side_a, side_b, params, *(f for f in (long_term, unexplained) if f)]
        report = _report(doc, command_line(ctx), inputs)
    emit_result(
        doc,
        lambda: _print(doc),
        output=output,
        report=report,
        report_path=report_path,
        as_json=json_output,
    )


def _print(doc: dict) -> None:
    from mtmetrology.formatting import format_k, format_result, format_uncertainty

    s, ref = doc["summary"], doc["reference"]
    reference = format_result(
        ref["value_mm"], ref["u_um"], "mm", name="reference length", u_unit="µm"
    )
    typer.echo(f"{reference} (eqs. 6-17, 6-19)")
    ks = doc["bipoints"]["k"]
    k = format_k(ks[0]) if max(ks) - min(ks) < 1e-9 else f"{min(ks):.3g} to {max(ks):.3g}"
    typer.echo(
        f"{s['bipoints']} bipoints: mean coverage (eq. 6-16) {100 * s['mean_coverage']:.1f} % "
        f"for p = {s['p']}, {s['holding']} intervals hold the reference, mean U = "
        f"{format_uncertainty(s['mean_U_um'])} µm (k = {k})"
    )
    if s["mean_coverage_without_e"] is not None:
        typer.echo(f"  without cov(e): {100 * s['mean_coverage_without_e']:.1f} %")
    low, high = s["binomial_region_99"]
    typer.echo(
        f"  binomial 99 % region if independent: {100 * low:.1f} … {100 * high:.1f} % "
        "(bipoints share their ends: wider in fact)"
    )


def _report(doc: dict, command: str, inputs: list[Path]):
    from mtmetrology.report import Report

    s = doc["summary"]
    rep = Report("Task validation: gauge bipoints", command=command, provenance={"inputs": inputs})
    rep.section(
        "Coverage",
        "Every side-A × side-B bipoint compensated with the calibration, its interval y ± U "
        "from the full-covariance GUF, against the calibrated length at the measurement "
        "temperature (Sepahi Boroujeni (2021), eqs. 6-16 to 6-19).",
    )
    rows = [
        ["bipoints", s["bipoints"]],
        ["mean coverage (eq. 6-16)", f"{100 * s['mean_coverage']:.1f} %"],
        ["intervals holding y_cal", s["holding"]],
        ["mean U", f"{s['mean_U_um']:.3g} µm"],
        ["binomial 99 % region (independent)", "{:.3f} … {:.3f}".format(*s["binomial_region_99"])],
    ]
    if s["mean_coverage_without_e"] is not None:
        rows.append(["mean coverage without cov(e)", f"{100 * s['mean_coverage_without_e']:.1f} %"])
    rep.table(["quantity", "value"], rows)
    return rep


@app.command("pooling")
@user_errors
def pooling(
    ctx: typer.Context,
    sets: Annotated[list[Path], typer.Argument(help="Point sets on the sphere, one CSV per pose.")],
    machine_name: MachineOption,
    params: Annotated[
        Path, typer.Option("--params", help="The calibration that compensates, with U_θ.")
    ],
    diameter_mm: Annotated[
        float, typer.Option("--diameter-mm", help="Calibrated diameter at 20 °C, mm.")
    ],
    diameter_u_um: Annotated[
        float, typer.Option("--diameter-u-um", help="Its standard uncertainty, µm (U/k).")
    ],
    sphericity_um: Annotated[
        float | None, typer.Option("--sphericity-um", help="Calibrated sphericity, µm.")
    ] = None,
    sphericity_u_um: Annotated[
        float, typer.Option("--sphericity-u-um", help="Its standard uncertainty, µm.")
    ] = 0.0,
    cte: CteOpt = 0.0,
    cte_u: CteUOpt = 0.0,
    delta_t: Annotated[float, typer.Option("--delta-t", help="Sphere temperature − 20 °C.")] = 0.0,
    delta_t_u: DeltaTUOpt = 0.0,
    repeatability: RepeatabilityOpt = None,
    unexplained: UnexplainedOpt = None,
    tip_diameter: TipDiameterOpt = None,
    k: Annotated[
        str | None, typer.Option("--k", help="Numbers of pooled sets, e.g. 1,2,3 (default all).")
    ] = None,
    draws: Annotated[int, typer.Option(help="Draws per k (the thesis: 200).")] = 200,
    points_per_draw: Annotated[int, typer.Option(help="Points per draw (the thesis: 25).")] = 25,
    seed: Annotated[int | None, typer.Option(help="Seed of the draws.")] = None,
    p: Annotated[float, typer.Option("--p", help="Coverage probability.")] = 0.95,
    json_output: Annotated[bool, typer.Option("--json", help="Print the result document.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write it here.")] = None,
    report_path: ReportOption = None,
) -> None:
    """Coverage of sphere diameter (and sphericity) intervals on draws pooled from k sets."""
    from mtmetrology.omm.validation_request import pooling_from_files
    from mtmetrology.units import to_internal

    try:
        k_values = None if k is None else [int(v) for v in k.split(",")]
    except ValueError:
        raise InputError(f"--k: expected integers separated by commas, got {k!r}") from None
    um = float(to_internal(1.0, "µm"))
    with progress_bar("pooling draws") as progress:
        result = pooling_from_files(
            sets,
            machine_name,
            params,
            diameter_mm,
            float(to_internal(diameter_u_um, "µm")),
            sphericity=None if sphericity_um is None else sphericity_um * um,
            sphericity_uncertainty=sphericity_u_um * um,
            expansion_coefficient=cte,
            expansion_coefficient_uncertainty=cte_u,
            temperature_difference=delta_t,
            temperature_difference_uncertainty=delta_t_u,
            repeatability=repeatability,
            unexplained=unexplained,
            tip_diameter=tip_diameter,
            k_values=k_values,
            draws=draws,
            points_per_draw=points_per_draw,
            p=p,
            seed=seed,
            progress=progress,
        )
    doc = result.to_dict()
    report = None
    if report_path is not None:
        report = _pooling_report(doc, command_line(ctx), [*sets, params])

    def summary() -> None:
        from mtmetrology.formatting import format_uncertainty

        for out in doc["outputs"]:
            typer.echo(f"{out['name']} (reference {out['reference']['value']:.5f} mm):")
            for row in out["per_k"]:
                used = f"{row['fits_used']} of {doc['draws']} draws"
                if row["coverage"] is None:
                    typer.echo(f"  k = {row['k']:>2}: no draw could be fitted ({used})")
                    continue
                typer.echo(
                    f"  k = {row['k']:>2}: coverage {100 * row['coverage']:5.1f} %, mean U "
                    f"{format_uncertainty(row['mean_U'] / um)} µm (p = {doc['p']:g}; {used})"
                )

    def messages() -> None:
        failed = result.failed
        if failed:
            typer.echo(
                f"warning: {len(failed)} draw(s) excluded, their sphere fit failed "
                "(not averaged into coverage or U):",
                err=True,
            )
            for fit in failed:
                typer.echo(f"  {fit.describe()}", err=True)

    emit_result(
        doc,
        summary,
        output=output,
        report=report,
        report_path=report_path,
        as_json=json_output,
        messages=messages,
    )


def _pooling_report(doc: dict, command: str, inputs: list[Path]):
    from mtmetrology.formatting import format_uncertainty
    from mtmetrology.report import Report
    from mtmetrology.units import to_internal

    um = float(to_internal(1.0, "µm"))
    rep = Report("Task validation: pooling test", command=command, provenance={"inputs": inputs})
    rep.section(
        "Coverage per number of pooled sets",
        f"{doc['draws']} draws of {doc['points_per_draw']} points from k pooled point sets, "
        "each compensated with its full-covariance GUF interval; coverage = mean of eq. 6-16 "
        "(Sepahi Boroujeni (2021), §6.5).",
    )
    for out in doc["outputs"]:
        rep.table(
            ["output", "k", "fits used", "coverage", "mean value (mm)", "mean U (µm)"],
            [
                [
                    out["name"],
                    row["k"],
                    f"{row['fits_used']} of {doc['draws']}",
                    *(
                        ["no fit", "", ""]
                        if row["coverage"] is None
                        else [
                            f"{100 * row['coverage']:.1f} %",
                            f"{row['mean_value']:.5f}",
                            format_uncertainty(row["mean_U"] / um),
                        ]
                    ),
                ]
                for row in out["per_k"]
            ],
            caption=f"U for p = {doc['p']:g} (k_p from the GUF); failed fits excluded.",
        )
    if doc["failed_fits"]:
        rep.table(
            ["k", "draw", "pooled sets", "why the fit failed"],
            [[f["k"], f["draw"], " + ".join(f["sets"]), f["reason"]] for f in doc["failed_fits"]],
            caption="Draws excluded from the coverage and the means: their sphere fit failed.",
        )
    return rep
