"""``mtm budget``: task-uncertainty budgets (ISO 15530-3, VDI/VDE 2617-11 with a map)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from mtmetrology.budgets.conformity import Tolerance
from mtmetrology.budgets.iso15530 import Policy, RepeatabilityMethod, iso15530_3_budget
from mtmetrology.cli._common import print_json, user_errors
from mtmetrology.errors import InputError
from mtmetrology.io import check_output, read_csv_table
from mtmetrology.io.files import write_json
from mtmetrology.report.format import format_uncertainty
from mtmetrology.units import to_internal

app = typer.Typer(help="Task-uncertainty budgets of on-machine measurements.", no_args_is_help=True)

ISO_HELP = """ISO 15530-3 budget of one characteristic from repeated cycles.

RUNS.csv: value[,series], one row per measurement cycle (mm); series labels the series
for --u-p max-over-series (each ≥ 10 cycles, ≥ 20 repeats in all).  b = mean − VALUE.
Uncertainties in µm.  --policy 2004: U = k·√(u_cal²+u_p²+u_w²) + |b|; 2011: b corrected,
U = k·√(u_cal²+u_p²+u_b²+u_w²); paper003 (default): u_b = |b| inside the root.  The
probe error enters in quadrature above 1 µm (small machine) or 3 µm (large).
"""


def _um(value: float, option: str) -> float:
    if not value >= 0:
        raise InputError(f"{option}: must be >= 0 µm, got {value}")
    return float(to_internal(value, "µm"))


@app.command("iso15530-3", help=ISO_HELP)
@user_errors
def iso15530_3(
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
    probe_u: Annotated[float, typer.Option("--probe-u", help="Probe systematic error (µm).")] = 0.0,
    machine_class: Annotated[
        str, typer.Option("--machine-class", help="small (1 µm) or large (3 µm) probe threshold.")
    ] = "small",
    k: Annotated[float, typer.Option("--k", help="Coverage factor.")] = 2.0,
    tolerance: Annotated[
        str | None,
        typer.Option("--tolerance", help="NOMINAL,LOWER,UPPER (mm): ISO 14253-1 decision."),
    ] = None,
    json: Annotated[bool, typer.Option("--json", help="Print the JSON document.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="JSON file.")] = None,
) -> None:
    if output is not None:
        check_output(output, [runs])
    tol = None if tolerance is None else Tolerance.parse(tolerance)
    table = read_csv_table(runs, required=["value"])
    series = table.strings("series") if table.has("series") else None
    budget = iso15530_3_budget(
        table.floats("value"),
        calibrated=calibrated,
        u_cal=_um(u_cal, "--u-cal"),
        u_w=_um(u_w, "--u-w"),
        u_b=_um(u_b, "--u-b"),
        series=None if series is None else np.asarray(series),
        policy=policy,
        repeatability_method=u_p_method,
        probe_error=_um(probe_u, "--probe-u"),
        machine_class=machine_class,
        k=k,
        tolerance=tol,
        name=runs.stem,
        provenance={"runs": str(runs)},
    )
    doc = budget.to_dict()
    if output is not None:
        write_json(output, doc)
    if json:
        print_json(doc)
        return
    um = doc["um"]
    typer.echo(
        f"ISO 15530-3 budget of {runs.name}, policy {budget.policy.value}, "
        f"n = {budget.n}, k = {budget.k:g} (µm)"
    )
    typer.echo(
        f"  mean {budget.mean:.6f} mm  calibrated {budget.calibrated:.6f} mm  b {um['b']:.2f}"
    )
    for name in ("u_b", "u_p", "u_cal", "u_w", "u_probe", "u", "U"):
        typer.echo(f"  {name:<8} {format_uncertainty(um[name])}")
    typer.echo(f"  result {budget.result:.6f} mm ± {format_uncertainty(um['U'])} µm")
    if budget.decision is not None:
        typer.echo(f"  decision (ISO 14253-1): {budget.decision.decision.value}")
