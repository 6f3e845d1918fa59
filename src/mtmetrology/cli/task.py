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

from dataclasses import replace
from enum import StrEnum
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from mtmetrology.cli._common import (
    ReportOption,
    command_line,
    print_json,
    readings_from_table,
    senses_from_table,
    user_errors,
    write_report,
)
from mtmetrology.cli._history import load_parameters
from mtmetrology.errors import InputError
from mtmetrology.fitting.composite import CombinedFeature, PointCoordinates
from mtmetrology.fitting.features import (
    BallCentre,
    CircleCentre,
    CircleDiameter,
    CylinderDiameter,
    Cylindricity,
    Flatness,
    GaugeLength,
    Roundness,
    SphereDiameter,
    Sphericity,
)
from mtmetrology.fitting.zone_features import (
    MinimumZoneCylindricity,
    MinimumZoneFlatness,
    MinimumZoneRoundness,
    MinimumZoneSphericity,
)
from mtmetrology.formatting import (
    SHARE_DEFINITION,
    format_share,
    format_uncertainty,
    format_value,
)
from mtmetrology.io import read_csv_table, write_json
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.omm.repeatability_file import load_repeatability_model
from mtmetrology.omm.task import TaskResult, reading_covariance, task_uncertainty
from mtmetrology.omm.unexplained import load_unexplained_covariance
from mtmetrology.uncertainty.conformity import Tolerance, decide
from mtmetrology.units import from_internal

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


#: The features with a form error, which ``--form minimum-zone`` may evaluate.
FORM_FEATURES = ("sphere", "circle", "plane", "cylinder")
#: Default side: a ball is probed from outside, a circle or a cylinder is a bore.
DEFAULT_SIDE = {"sphere": Side.outer, "circle": Side.inner, "cylinder": Side.inner}


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


def task_feature(name: FeatureName, form: Form, side: Side | None, d_tip: float, n_points: int):
    """The feature function g(q): the size (tip-compensated, least squares) and the form
    (least-squares peak-to-valley or minimum zone) of the element, its centre, or the
    compensated coordinates themselves (Sepahi Boroujeni (2021), Table 7-1)."""
    inner = (side or DEFAULT_SIDE.get(name.value, Side.outer)) is Side.inner
    zone = form is Form.minimum_zone
    parts = {
        FeatureName.length: lambda: (GaugeLength(tip_diameter=d_tip),),
        FeatureName.sphere: lambda: (
            SphereDiameter(d_tip, inner=inner),
            MinimumZoneSphericity() if zone else Sphericity(),
        ),
        FeatureName.circle: lambda: (
            CircleDiameter(inner=inner, tip_diameter=d_tip),
            MinimumZoneRoundness() if zone else Roundness(),
        ),
        FeatureName.plane: lambda: (MinimumZoneFlatness() if zone else Flatness(),),
        FeatureName.cylinder: lambda: (
            CylinderDiameter(inner=inner, tip_diameter=d_tip),
            MinimumZoneCylindricity() if zone else Cylindricity(),
        ),
        FeatureName.sphere_centre: lambda: (BallCentre(name="sphere_centre"),),
        FeatureName.circle_centre: lambda: (CircleCentre(),),
        FeatureName.points: lambda: (PointCoordinates(n_points),),
    }[name]()
    return parts[0] if len(parts) == 1 else CombinedFeature(parts)


@app.command("uncertainty")
@user_errors
def uncertainty(
    ctx: typer.Context,
    points_csv: Annotated[
        Path, typer.Argument(help="Probed readings: point,X,Y,Z,B,C[,i,j,k][,end].")
    ],
    machine_name: Annotated[str, typer.Option("--machine", help="Preset name or machine YAML.")],
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
            "calibrations (mtm long-term), or history:MACHINE (from the calibration "
            "history); only its covariance is used.",
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
    p: Annotated[float, typer.Option("--p", help="Coverage probability.")] = 0.95,
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
    tol = Tolerance.parse(tolerance) if tolerance is not None else None
    if recalibrated and long_term is not None:
        raise InputError(
            "--long-term and --recalibrated: a machine recalibrated for the task has no "
            "long-term term; give one of them"
        )
    if not recalibrated and long_term is None:
        raise InputError(
            "state the long-term variation of the parameters since the calibration: "
            "--long-term FILE (mtm calibrate long-term), or --recalibrated"
        )
    if side is not None and feature.value not in DEFAULT_SIDE:
        raise InputError(
            f"--side applies to a sphere, circle or cylinder, not to a {feature.value}"
        )
    if form is Form.minimum_zone and feature.value not in FORM_FEATURES:
        raise InputError(f"--form minimum-zone applies to a form error, not to a {feature.value}")
    base = Machine.load(machine_name)
    pset = ParameterSet.load(params, base)
    machine = pset.machine_for(base)
    if pset.covariance is None:
        raise InputError(f"{params}: no covariance; the task uncertainty needs one")
    sigma_lt = None
    if long_term is not None:
        lt = load_parameters(long_term, base)
        if lt.covariance is None:
            raise InputError(f"{long_term}: no covariance; --long-term needs one")
        if set(lt.names) != set(pset.names):
            raise InputError(f"{long_term}: parameter names differ from those of {params}")
        sigma_lt = _ordered_covariance(lt, machine)
    readings, approach, senses = _points(points_csv, machine, feature, repeatability is not None)
    d_tip = 2.0 * machine.tip_radius if tip_diameter is None else tip_diameter
    feat = task_feature(feature, form, side, d_tip, len(readings))
    if len(readings) < feat.min_points:
        raise InputError(
            f"{points_csv}: a {feature.value} needs at least {feat.min_points} points "
            f"({form.value}), got {len(readings)}"
        )
    v = None
    if repeatability is not None:
        v = reading_covariance(machine, load_repeatability_model(repeatability), readings, approach)
    cov_e = load_unexplained_covariance(unexplained) if unexplained is not None else None
    target = _tolerance_index(feat, tolerance_output, tol)
    result = task_uncertainty(
        machine,
        readings,
        pset.vector_for(machine),
        _ordered_covariance(pset, machine),
        feat,
        long_term_covariance=sigma_lt,
        recalibrated=recalibrated,
        reading_covariance=v,
        unexplained_covariance=cov_e,
        senses=senses,
        p=p,
        method=method.value,
        simulator=simulator.value,
        draws=draws,
        trials=trials,
        digits=digits,
        seed=seed,
    )
    if tol is not None:
        out = result.result.outputs[target]
        decision = decide(out.value, out.U, tol, guard_band_factor=guard_band_factor, unit="mm")
        result = replace(result, decision=decision)
    document = result.to_dict()
    document["source"] = {"points": str(points_csv), "params": str(params)}
    if long_term is not None:
        document["source"]["long_term"] = str(long_term)
    if report_path is not None:
        optional = (long_term, repeatability, unexplained)
        inputs = [points_csv, params, *(f for f in optional if f is not None)]
        _write_report(report_path, result, command_line(ctx), inputs, target)
    if output is not None:
        write_json(output, document)
    if json_output:
        print_json(document)
    else:
        _print(result, {"repeatability": repeatability, "unexplained": unexplained})


def _label(group: str) -> str:
    """A budget group's name in words: ``long_term_variation`` -> ``long-term variation``."""
    return group.replace("long_term", "long-term").replace("_", " ")


def _ordered_covariance(pset: ParameterSet, machine: Machine) -> np.ndarray:
    """The set's covariance in ``machine.parameter_names`` order."""
    order = [pset.names.index(n) for n in machine.parameter_names]
    return pset.covariance[np.ix_(order, order)]


def _tolerance_index(feature, name: str | None, tol: Tolerance | None) -> int:
    """Index of the toleranced output: the named one, else the feature's first."""
    names = list(feature.output_names)
    if name is None:
        return 0
    if tol is None:
        raise InputError("--tolerance-output needs --tolerance")
    if name not in names:
        raise InputError(f"--tolerance-output: {name!r} is not an output ({', '.join(names)})")
    return names.index(name)


def _write_report(
    path: Path, result: TaskResult, command: str, inputs: list[Path], target: int
) -> None:
    """Values with u and U, the budget by source, the validation and the decision."""
    from mtmetrology.report import Report, figures
    from mtmetrology.report.results import add_result

    r = result.result
    name = r.names[target]
    rep = Report(f"Task uncertainty: {name}", command=command, provenance={"inputs": inputs})
    how = {
        "guf": "GUF",
        "mcm": "adaptive Monte Carlo (JCGM 101:2008, 7.9)",
        "both": "adaptive Monte Carlo, with the GUF validated against it (JCGM 101:2008, 8)",
    }[result.method]
    rep.section(
        "Result",
        f"{how} of the compensated points through the feature (full-covariance method of "
        "Sepahi Boroujeni (2021), Ch. 6), compensated with the calibration's estimate: "
        "repeatability, the calibration's parameter covariance, the long-term variation of "
        f"the parameters ({result.long_term}) and unexplained volumetric errors; "
        f"{result.inputs.simulator} covariance simulator.",
    )
    rows = []
    for o in r.outputs:
        u_um, big_u_um = float(from_internal(o.u, "µm")), float(from_internal(o.U, "µm"))
        low, high = o.interval
        rows.append(
            [
                o.name,
                f"{format_value(o.value, o.u)} mm",
                f"{format_uncertainty(u_um)} µm",
                f"{format_uncertainty(big_u_um)} µm",
                f"{o.k:.3f}",
                o.p,
                f"[{format_value(low, o.u)}, {format_value(high, o.u)}] mm",
            ]
        )
    rep.table(["output", "value", "u", "U", "k", "p", "interval"], rows)
    sources = list(result.shares)
    shares = [float(result.shares[k][target]) for k in sources]
    rep.section("Budget by source (first order)")
    rep.table(
        ["source", "share of u_c²"],
        [[_label(k), format_share(v)] for k, v in zip(sources, shares, strict=True)],
        caption=f"{SHARE_DEFINITION}; the sources are independent, so their shares add.",
    )
    rep.figure(
        figures.budget_bars(
            [_label(k) for k in sources],
            shares,
            title=f"Uncertainty budget of {name}",
        ),
        caption="Share of u_c² of each source, as in the table.",
    )
    if result.validation is not None:
        add_result(rep, result.validation, units=dict(zip(r.names, r.units, strict=True)))
    if result.decision is not None:
        d = result.decision.to_dict()
        tol = result.decision.tolerance
        value, big_u = float(r.outputs[target].value), float(r.outputs[target].U)
        lower = tol.lower_limit if np.isfinite(tol.lower_limit) else None
        upper = tol.upper_limit if np.isfinite(tol.upper_limit) else None
        rep.section(f"Conformity decision of {name} (ISO 14253-1:2017)", str(d["decision"]))
        rep.figure(figures.conformity_zones(value, big_u, lower, upper, name=name, unit="mm"))
    write_report(rep, path)


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
    r = result.result
    absent = [NOT_GIVEN[option] for option, path in given.items() if path is None]
    omit = {source for source, _ in absent}
    if result.long_term != "propagated":  # recalibrated: no such term, said on its own line
        omit.add("long_term_variation")
    for j, o in enumerate(r.outputs):
        u_um, big_u_um = float(from_internal(o.u, "µm")), float(from_internal(o.U, "µm"))
        typer.echo(
            f"{o.name} = {format_value(o.value, o.u)} mm, u = {format_uncertainty(u_um)} µm, "
            f"U = {format_uncertainty(big_u_um)} µm (k = {o.k:.2f}, p = {o.p})"
        )
        shares = ", ".join(
            f"{_label(k)} {format_share(v[j])}" for k, v in result.shares.items() if k not in omit
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
