"""``mtm task uncertainty``: value, uncertainty and conformity of an on-machine measurement.

The probed readings are compensated with the machine parameters of a calibration and
the feature (gauge length, sphere diameter) is evaluated with its uncertainty by the
full-covariance GUF (Sepahi Boroujeni (2021), ch. 6–7; measurement model in
:mod:`mtmetrology.omm.task`): the calibration's parameter covariance (``--params``, always),
the long-term variation of the parameters since the calibration (``--long-term``, unless
``--recalibrated``), repeatability of the readings (``--repeatability``) and unexplained
volumetric errors (``--unexplained``).
"""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

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
from mtmetrology.cli._history import HISTORY_PARAMS, load_parameters

if TYPE_CHECKING:
    from mtmetrology.omm.task import TaskResult

__all__ = ["app"]

app = typer.Typer(help="Uncertainty of on-machine measurement tasks.", no_args_is_help=True)


class FeatureName(StrEnum):
    length = "length"
    sphere = "sphere"
    circle = "circle"
    plane = "plane"
    cylinder = "cylinder"
    sphere_centre = "sphere-centre"
    circle_centre = "circle-centre"
    points = "points"


class Form(StrEnum):
    least_squares = "least-squares"
    minimum_zone = "minimum-zone"


class Side(StrEnum):
    inner = "inner"
    outer = "outer"


class Method(StrEnum):
    guf = "guf"
    mcm = "mcm"
    both = "both"


class Simulator(StrEnum):
    linear = "linear"
    sampled = "sampled"


@app.callback()
def _group() -> None:
    """Uncertainty of on-machine measurement tasks."""


@app.command("uncertainty")
@user_errors
def uncertainty(
    ctx: typer.Context,
    points_csv: Annotated[
        Path, typer.Argument(help="Probed readings: point,X,Y,Z,B,C[,i,j,k][,end].")
    ],
    machine_name: MachineOption,
    params: Annotated[
        Path,
        typer.Option("--params", help="The calibration that compensates, with its covariance U_θ."),
    ],
    feature: Annotated[FeatureName, typer.Option(help="Feature of the point set.")],
    long_term: Annotated[
        Path | None,
        typer.Option(
            "--long-term",
            help="Parameter set whose covariance is the variation of the parameters between "
            "calibrations (mtm long-term), or history:MACHINE[@DB] (from the calibration "
            "history, DB a file or URL [$MTMETROLOGY_DB]); only its covariance is used.",
        ),
    ] = None,
    recalibrated: Annotated[
        bool,
        typer.Option(
            "--recalibrated", help="The machine is recalibrated for the task: no long-term term."
        ),
    ] = False,
    repeatability: Annotated[
        Path | None, typer.Option(help="repeatability-model JSON (mtm repeatability fit).")
    ] = None,
    unexplained: Annotated[
        Path | None, typer.Option(help="unexplained-volumetric-error document (µm²).")
    ] = None,
    form: Annotated[
        Form,
        typer.Option(
            help="Form error by the least-squares element or the minimum zone (ISO 1101; "
            "about 2–60 ms per Monte Carlo trial)."
        ),
    ] = Form.least_squares,
    side: Annotated[
        Side | None,
        typer.Option(
            help="Probed from inside (bore) or outside; default: ball outer, circle inner."
        ),
    ] = None,
    tip_diameter: Annotated[
        float | None, typer.Option(help="Effective tip diameter, mm (default: the machine's).")
    ] = None,
    method: Annotated[
        Method, typer.Option(help="GUF, adaptive Monte Carlo, or both with the validation.")
    ] = Method.guf,
    simulator: Annotated[
        Simulator, typer.Option(help="Covariance simulator: linearised or sampled (Q draws).")
    ] = Simulator.linear,
    draws: Annotated[int, typer.Option(help="Q of the sampled simulator.")] = 10_000,
    trials: Annotated[
        int | None, typer.Option(help="Fixed Monte Carlo trials (default: adaptive).")
    ] = None,
    digits: Annotated[
        int, typer.Option(help="Significant digits of u that the adaptive run stabilises.")
    ] = 2,
    seed: Annotated[int | None, typer.Option(help="Seed of every random stream.")] = None,
    tolerance: Annotated[
        str | None,
        typer.Option(help="NOMINAL,LOWER,UPPER in mm (deviations; one side may be empty)."),
    ] = None,
    tolerance_output: Annotated[
        str | None,
        typer.Option(help="Output the tolerance applies to (default: the feature's first)."),
    ] = None,
    guard_band_factor: Annotated[
        float, typer.Option(help="Guard bands h·U (ISO 14253-1:2017 default h = 1).")
    ] = 1.0,
    k: CoverageK = None,
    p: CoverageP = None,
    json_output: Annotated[bool, typer.Option("--json", help="Print the result document.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write it here.")] = None,
    report_path: ReportOption = None,
) -> None:
    """Value, u, U, budget and ISO 14253-1 decision of a feature probed on the machine.

    POINTS.csv holds one row per probed point: ``point`` and the readings of every axis
    (linear mm, rotary degrees); ``i,j,k`` (approach direction) when ``--repeatability``
    is given; for ``--feature length`` two rows, ordered by an optional ``end`` (1, 2).
    Features: length (gauge length), sphere (diameter, sphericity), circle (diameter,
    roundness), plane (flatness), cylinder (diameter, cylindricity), sphere-centre and
    circle-centre (positions), points (the compensated coordinates). Sizes and centres are
    least squares; ``--form minimum-zone`` evaluates the form error by the minimum zone.
    The budget separates the calibration (--params covariance U_θ, always propagated:
    the readings are compensated with its estimate), the long-term variation
    (--long-term; one of --long-term and --recalibrated is required), the repeatability
    and E; with neither --repeatability nor --unexplained, u is the calibration's
    contribution.
    Method: GUF with the covariance simulator, adaptive Monte Carlo (JCGM 101/102), or both
    with the validation of the GUF.
    """
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.omm.task_request import task_uncertainty_from_files

    lt = long_term
    if long_term is not None and str(long_term).startswith(HISTORY_PARAMS):
        lt = load_parameters(long_term, Machine.load(machine_name))
    result = task_uncertainty_from_files(
        points_csv,
        machine_name,
        params,
        feature.value,
        long_term=lt,
        long_term_source=None if long_term is None else str(long_term),
        recalibrated=recalibrated,
        repeatability=repeatability,
        unexplained=unexplained,
        form=form.value,
        side=None if side is None else side.value,
        tip_diameter=tip_diameter,
        method=method.value,
        simulator=simulator.value,
        draws=draws,
        trials=trials,
        digits=digits,
        seed=seed,
        tolerance=tolerance,
        tolerance_output=tolerance_output,
        guard_band_factor=guard_band_factor,
        p=coverage_from_options(k, p).p,
    )
    report = None
    if report_path is not None:
        optional = (long_term, repeatability, unexplained)
        inputs = [points_csv, params, *(f for f in optional if f is not None)]
        report = _report(result, command_line(ctx), inputs)
    emit_result(
        result.to_dict(),
        lambda: _print(result, {"repeatability": repeatability, "unexplained": unexplained}),
        output=output,
        report=report,
        report_path=report_path,
        as_json=json_output,
    )


def _report(result: TaskResult, command: str, inputs: list[Path]):
    """The report of the result (:mod:`mtmetrology.omm.report`), titled by its target output."""
    from mtmetrology.report import Report
    from mtmetrology.report.results import add_result

    name = result.result.names[result.target]
    rep = Report(f"Task uncertainty: {name}", command=command, provenance={"inputs": inputs})
    return add_result(rep, result)


#: What the computation uses for a source whose file was not given (console notes).
NOT_GIVEN = {
    "repeatability": (
        "repeatability",
        "no repeatability model given (--repeatability): the readings are taken as exact "
        "(zero reading covariance)",
    ),
    "unexplained": (
        "unexplained_volumetric_error",
        "no unexplained-volumetric-error document given (--unexplained): taken as zero",
    ),
}


def _print(result: TaskResult, given: dict[str, Path | None]) -> None:
    """Console summary; a source without its file is named as absent, not as 0.0 %."""
    from mtmetrology.formatting import (
        format_coverage,
        format_share,
        format_uncertainty,
        format_value,
    )
    from mtmetrology.omm.simulator import group_label
    from mtmetrology.units import from_internal

    r = result.result
    absent = [NOT_GIVEN[option] for option, path in given.items() if path is None]
    omit = {source for source, _ in absent}
    if result.long_term != "propagated":  # recalibrated: no such term, said on its own line
        omit.add("long_term_variation")
    for j, o in enumerate(r.outputs):
        u_um, big_u_um = float(from_internal(o.u, "µm")), float(from_internal(o.U, "µm"))
        typer.echo(
            f"{o.name} = {format_value(o.value, o.u)} mm, u = {format_uncertainty(u_um)} µm, "
            f"U = {format_uncertainty(big_u_um)} µm ({format_coverage(o.k, o.p)})"
        )
        shares = ", ".join(
            f"{group_label(k)} {format_share(v[j])}"
            for k, v in result.shares.items()
            if k not in omit
        )
        typer.echo(f"  first-order budget: {shares}")
    typer.echo(f"  long-term variation of the parameters: {result.long_term}")
    for _, note in absent:
        typer.echo(note)
    if result.mcm is not None:
        typer.echo(
            f"Monte Carlo: {result.mcm.trials} trials"
            + ("" if result.mcm.converged is None else f", converged: {result.mcm.converged}")
        )
    if result.validation is not None:
        typer.echo(f"GUF validated by Monte Carlo: {result.validation.passed}")
    if result.decision is not None:
        typer.echo(f"decision (ISO 14253-1:2017): {result.decision.decision.value}")
