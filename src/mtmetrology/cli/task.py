"""``mtm task uncertainty``: value, uncertainty and conformity of an on-machine measurement.

The probed readings are compensated with the machine parameters of a calibration and
the feature (gauge length, sphere diameter) is evaluated with its uncertainty by the
full-covariance GUF (Sepahi Boroujeni (2021), ch. 6–7): repeatability of the readings
(``--repeatability``), long-term covariance of the machine parameters (``--params``) and
unexplained volumetric errors (``--unexplained``).
"""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from mtmetrology.budgets.conformity import Tolerance, decide
from mtmetrology.cli._common import (
    ReportOption,
    command_line,
    print_json,
    readings_from_table,
    senses_from_table,
    user_errors,
    write_report,
)
from mtmetrology.errors import InputError
from mtmetrology.fitting.features import GaugeLength, SphereDiameter
from mtmetrology.io import read_csv_table, write_json
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.omm.repeatability_file import load_repeatability_model
from mtmetrology.omm.task import TaskResult, reading_covariance, task_uncertainty
from mtmetrology.omm.unexplained import load_unexplained_covariance
from mtmetrology.units import from_internal

app = typer.Typer(help="Uncertainty of on-machine measurement tasks.", no_args_is_help=True)


class FeatureName(StrEnum):
    length = "length"
    sphere = "sphere"


@app.callback()
def _group() -> None:
    """Uncertainty of on-machine measurement tasks."""


def _points(path: Path, machine: Machine, feature: FeatureName, need_approach: bool):
    table = read_csv_table(path, required=("point",))
    readings = readings_from_table(machine, table)
    order = np.arange(len(table))
    if feature is FeatureName.length:
        if len(table) != 2:
            raise InputError(
                f"{path}: a length needs exactly 2 points (one pair), got {len(table)}"
            )
        if table.has("end"):
            ends = table.floats("end")
            if sorted(ends.tolist()) != [1.0, 2.0]:
                raise InputError(f"{path}: column 'end' must hold 1 and 2")
            order = np.argsort(ends)
    approach = None
    if need_approach:
        approach = np.column_stack([table.floats(c) for c in "ijk"])
    senses = senses_from_table(machine, table)
    return (
        readings[order],
        None if approach is None else approach[order],
        None if senses is None else senses[order],
    )


@app.command("uncertainty")
@user_errors
def uncertainty(
    ctx: typer.Context,
    points_csv: Annotated[
        Path, typer.Argument(help="Probed readings: point,X,Y,Z,B,C[,i,j,k][,end].")
    ],
    machine_name: Annotated[str, typer.Option("--machine", help="Preset name or machine YAML.")],
    params: Annotated[
        Path, typer.Option("--params", help="Parameter set with its long-term covariance.")
    ],
    feature: Annotated[FeatureName, typer.Option(help="Feature of the point set.")],
    repeatability: Annotated[
        Path | None, typer.Option(help="repeatability-model JSON (mtm repeatability fit).")
    ] = None,
    unexplained: Annotated[
        Path | None, typer.Option(help="unexplained-volumetric-error document (µm²).")
    ] = None,
    tip_diameter: Annotated[
        float | None, typer.Option(help="Effective tip diameter, mm (default: the machine's).")
    ] = None,
    tolerance: Annotated[
        str | None,
        typer.Option(help="NOMINAL,LOWER,UPPER in mm (deviations; one side may be empty)."),
    ] = None,
    guard_band_factor: Annotated[
        float, typer.Option(help="Guard bands h·U (ISO 14253-1:2017 default h = 1).")
    ] = 1.0,
    p: Annotated[float, typer.Option("--p", help="Coverage probability.")] = 0.95,
    json_output: Annotated[bool, typer.Option("--json", help="Print the result document.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="Write it here.")] = None,
    report_path: ReportOption = None,
) -> None:
    """Value, u, U, budget and ISO 14253-1 decision of a feature probed on the machine.

    POINTS.csv holds one row per probed point: ``point`` and the readings of every axis
    (linear mm, rotary degrees); ``i,j,k`` (approach direction) when ``--repeatability``
    is given; for ``--feature length`` two rows, ordered by an optional ``end`` (1, 2).
    Method: GUF with the linearised covariance simulator (machine-parameter uncertainty
    cancels to first order; the parameters enter the compensated value).
    """
    tol = Tolerance.parse(tolerance) if tolerance is not None else None
    if repeatability is None and unexplained is None:
        raise InputError(
            "give --repeatability and/or --unexplained: the machine-parameter uncertainty "
            "alone cancels to first order (u would be 0)"
        )
    base = Machine.load(machine_name)
    pset = ParameterSet.load(params, base)
    machine = pset.machine_for(base)
    if pset.covariance is None:
        raise InputError(f"{params}: no covariance; the task uncertainty needs one")
    readings, approach, senses = _points(points_csv, machine, feature, repeatability is not None)
    v = None
    if repeatability is not None:
        v = reading_covariance(machine, load_repeatability_model(repeatability), readings, approach)
    cov_e = load_unexplained_covariance(unexplained) if unexplained is not None else None
    d_tip = 2.0 * machine.tip_radius if tip_diameter is None else tip_diameter
    feat = (
        GaugeLength(tip_diameter=d_tip) if feature is FeatureName.length else SphereDiameter(d_tip)
    )
    result = task_uncertainty(
        machine,
        readings,
        pset.vector_for(machine),
        pset.covariance,
        feat,
        reading_covariance=v,
        unexplained_covariance=cov_e,
        senses=senses,
        p=p,
    )
    if tol is not None:
        decision = decide(
            float(result.guf.estimate[0]),
            float(result.guf.expanded_uncertainty[0]),
            tol,
            guard_band_factor=guard_band_factor,
            unit="mm",
        )
        result = TaskResult(
            result.guf, result.points, result.points_covariance, result.shares, decision
        )
    document = result.to_dict()
    document["source"] = {"points": str(points_csv), "params": str(params)}
    if report_path is not None:
        inputs = [points_csv, params, *(f for f in (repeatability, unexplained) if f is not None)]
        _write_report(report_path, result, command_line(ctx), inputs)
    if output is not None:
        write_json(output, document)
    if json_output:
        print_json(document)
    else:
        _print(result)


def _write_report(path: Path, result: TaskResult, command: str, inputs: list[Path]) -> None:
    """Value with u and U, the budget by source, and the ISO 14253-1 decision."""
    from mtmetrology.report import Report, figures

    g = result.guf
    name, value = g.names[0], float(g.estimate[0])
    u, big_u = float(g.standard_uncertainty[0]), float(g.expanded_uncertainty[0])
    rep = Report(f"Task uncertainty: {name}", command=command, provenance={"inputs": inputs})
    rep.section(
        "Result",
        "GUF of the compensated points through the feature (full-covariance method of "
        "Sepahi Boroujeni (2021), Ch. 6): repeatability, machine parameters and unexplained "
        "volumetric errors; the machine-parameter share cancels to first order.",
    )
    rep.table(
        ["feature", "value", "u", "U", "k", "p", "interval", "unit"],
        [
            [
                name,
                f"{value:.6f}",
                f"{from_internal(u, 'µm'):.3g} µm",
                f"{from_internal(big_u, 'µm'):.3g} µm",
                f"{float(g.coverage_factor[0]):.3f}",
                g.p,
                f"[{g.interval[0][0]:.6f}, {g.interval[0][1]:.6f}]",
                "mm",
            ]
        ],
    )
    sources = list(result.shares)
    shares = [float(result.shares[k][0]) for k in sources]
    rep.section("Budget by source")
    rep.table(
        ["source", "share of u²"],
        [[k.replace("_", " "), f"{100 * v:.1f} %"] for k, v in zip(sources, shares, strict=True)],
    )
    rep.figure(
        figures.budget_bars(
            [k.replace("_", " ") for k in sources],
            [float(from_internal(u, "µm")) * max(v, 0.0) ** 0.5 for v in shares],
            unit="µm",
            title=f"Uncertainty budget of {name}",
        ),
        caption="Contribution of each source, u·√share (the squares add to u²).",
    )
    if result.decision is not None:
        d = result.decision.to_dict()
        tol = result.decision.tolerance
        lower = tol.lower_limit if np.isfinite(tol.lower_limit) else None
        upper = tol.upper_limit if np.isfinite(tol.upper_limit) else None
        rep.section("Conformity decision (ISO 14253-1:2017)", str(d["decision"]))
        rep.figure(figures.conformity_zones(value, big_u, lower, upper, name=name, unit="mm"))
    write_report(rep, path)


def _print(result: TaskResult) -> None:
    g = result.guf
    u_um = from_internal(g.standard_uncertainty[0], "µm")
    big_u_um = from_internal(g.expanded_uncertainty[0], "µm")
    typer.echo(
        f"{g.names[0]} = {g.estimate[0]:.4f} mm, u = {u_um:.2f} µm, "
        f"U = {big_u_um:.2f} µm (k = {g.coverage_factor[0]:.2f}, p = {g.p})"
    )
    shares = ", ".join(
        f"{k.replace('_', ' ')} {100 * v[0] + 0.0:.1f} %" for k, v in result.shares.items()
    )
    typer.echo(f"budget: {shares}")
    if result.decision is not None:
        typer.echo(f"decision (ISO 14253-1:2017): {result.decision.decision.value}")
