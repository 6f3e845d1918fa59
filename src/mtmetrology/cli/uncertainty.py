"""``mtm uncertainty``: measurement-model files through GUF and Monte Carlo.

``mtm uncertainty run MODEL.yaml --method guf|mcm|both`` prints the uncertainty
budget, the estimates with u, U, k and coverage intervals and, when both methods
ran, the validation of the GUF by Monte Carlo (JCGM 101 §8, JCGM 102 §8).
``--json`` prints the result document instead::

    {"kind": "uncertainty-result", "version": 1, "method": "both",
     "outputs": [{name, value, unit, u, U, k, p, interval, method, ...}],
     "guf": {...}, "mcm": {...}, "validation": {...}}

``outputs`` holds the GUF results for ``--method guf`` and the Monte Carlo results
otherwise (Monte Carlo is the reference against which the GUF is validated); the
full results of each method are under ``guf`` and ``mcm``.
"""

from __future__ import annotations

import json
import math
from enum import StrEnum
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from mtmetrology.cli._common import fail
from mtmetrology.errors import ConvergenceError, ResourceLimitError
from mtmetrology.uncertainty.guf import GUFResult, guf
from mtmetrology.uncertainty.modelfile import MeasurementModel, ModelFileError, load_model

RESULT_KIND = "uncertainty-result"
RESULT_VERSION = 1
#: Most Monte Carlo values kept for the coverage intervals (trials x outputs): 400 MB.
MAX_VALUES = 50_000_000
#: Most significant digits an adaptive run may be asked for (JCGM 101:2008, 7.9.2 uses
#: 1 or 2; each further digit costs 100 times the trials).
MAX_DIGITS = 3

app = typer.Typer(help="Evaluate measurement uncertainty (GUF, Monte Carlo).", no_args_is_help=True)


class Method(StrEnum):
    guf = "guf"
    mcm = "mcm"
    both = "both"


@app.callback()
def _group() -> None:
    """Evaluate measurement uncertainty (GUF, Monte Carlo)."""


def _fail(message: str) -> None:
    fail(message)


def _decimals(u: float) -> int:
    """Decimals that show u with two significant digits (JCGM 100, 7.2.6)."""
    if not math.isfinite(u) or u <= 0:
        return 6
    return max(0, 1 - math.floor(math.log10(u)))


def _fmt(value: float, u: float) -> str:
    return f"{value:.{_decimals(u)}f}"


def _guf_outputs(r: GUFResult) -> list[dict]:
    return [{**o, "method": "guf"} for o in r.to_dict()["outputs"]]


def _mcm_outputs(r, names, units) -> list[dict]:
    outputs = []
    for j, name in enumerate(names):
        low, high = (float(v) for v in r.interval_symmetric[j])
        u = float(r.standard_uncertainty[j])
        half = 0.5 * (high - low)
        outputs.append(
            {
                "name": name,
                "value": float(r.estimate[j]),
                "unit": units[j],
                "u": u,
                "U": half,
                "k": half / u if u > 0 else None,
                "p": r.p,
                "interval": [low, high],
                "interval_shortest": [float(v) for v in r.interval_shortest[j]],
                "method": "mcm",
            }
        )
    return outputs


def _budget_table(r: GUFResult, j: int) -> Table:
    correlated = not np.allclose(r.input_covariance, np.diag(np.diag(r.input_covariance)))
    unit = f" in {r.units[j]}" if r.units[j] else ""
    table = Table(title=f"Uncertainty budget of {r.names[j]}{unit} (GUF)")
    for col in ("input", "estimate", "u(x_i)", "unit", "c_i", "u_i(y)", "dof", "share"):
        table.add_column(col, justify="left" if col in ("input", "unit") else "right")
    if correlated:
        table.add_column("share (with covariances)", justify="right")
    for row in r.budget(j):
        cells = [
            row.input,
            f"{row.estimate:.10g}",
            f"{row.u:.3g}",
            row.unit,
            f"{row.sensitivity + 0.0:.4g}",  # + 0.0 turns -0 into 0
            f"{row.contribution:.3g}",
            "inf" if math.isinf(row.dof) else f"{row.dof:g}",
            f"{100 * row.share:.1f} %",
        ]
        if correlated:
            cells.append(f"{100 * row.share_full:.1f} %")
        table.add_row(*cells)
    return table


def _results_table(title: str, outputs: list[dict], extra: str | None = None) -> Table:
    table = Table(title=title)
    for col in ("output", "value", "u", "U", "k", "interval", "unit"):
        table.add_column(col, justify="left" if col in ("output", "unit") else "right")
    if extra:
        table.add_column(extra, justify="right")
    for o in outputs:
        u = o["u"]
        cells = [
            o["name"],
            _fmt(o["value"], u),
            f"{u:.2g}",
            f"{o['U']:.2g}",
            "-" if o["k"] is None else f"{o['k']:.3f}",
            f"[{_fmt(o['interval'][0], u)}, {_fmt(o['interval'][1], u)}]",
            o["unit"],
        ]
        if extra == "dof":
            cells.append("inf" if o["dof"] is None else f"{o['dof']:.1f}")
        elif extra == "shortest interval":
            lo, hi = o["interval_shortest"]
            cells.append(f"[{_fmt(lo, u)}, {_fmt(hi, u)}]")
        table.add_row(*cells)
    return table


def _run_mcm(loaded: MeasurementModel, *, trials, adaptive, digits, seed, p, executor):
    from mtmetrology.uncertainty.mcm import monte_carlo

    return monte_carlo(
        loaded.model,
        loaded.inputs,
        trials=trials,
        adaptive=adaptive,
        digits=digits,
        p=p,
        seed=seed,
        executor=executor,
        max_trials=min(10_000_000, MAX_VALUES // len(loaded.output_names)),
    )


def _validate(g: GUFResult, r, digits: int, names):
    from mtmetrology.uncertainty.mcm import Tolerance, numerical_tolerance
    from mtmetrology.uncertainty.validation import validate_guf

    tolerance = r.tolerance or Tolerance(numerical_tolerance(r.standard_uncertainty, digits))
    scalar = len(names) == 1
    return validate_guf(
        g.estimate,
        g.covariance,
        r,
        tolerance=tolerance,
        p=g.p,
        guf_coverage_factor=None if scalar else g.region_coverage_factor,
        guf_interval=g.interval[0] if scalar else None,
        names=names,
    )


@app.command("run")
def run(
    model_file: Annotated[Path, typer.Argument(help="Measurement-model YAML file.")],
    method: Annotated[Method, typer.Option(help="guf, mcm or both.")] = Method.guf,
    trials: Annotated[int | None, typer.Option(help="Fixed number of MCM trials.")] = None,
    adaptive: Annotated[bool, typer.Option(help="Adaptive MCM (JCGM 101 7.9).")] = False,
    digits: Annotated[int, typer.Option(help="Significant digits for the tolerance.")] = 2,
    seed: Annotated[int | None, typer.Option(help="Seed of the random streams.")] = None,
    p: Annotated[float, typer.Option("--p", help="Coverage probability.")] = 0.95,
    executor: Annotated[
        str | None,
        typer.Option(help="inprocess, processes[:n], dask-local[:n] or a Dask address."),
    ] = None,
    as_json: Annotated[
        bool, typer.Option("--json", help="Print the result document as JSON.")
    ] = False,
) -> None:
    """Evaluate a measurement model by GUF, Monte Carlo, or both (with validation)."""
    if not 0.0 < p < 1.0:
        _fail(f"--p must lie in (0, 1), got {p}")
    if method is Method.guf and (trials is not None or adaptive):
        _fail("--trials and --adaptive apply to --method mcm or both")
    if trials is not None and adaptive:
        _fail("give either --trials N or --adaptive, not both")
    if not 1 <= digits <= MAX_DIGITS:
        _fail(f"--digits must be 1 to {MAX_DIGITS} significant digits, got {digits}")
    try:
        loaded = load_model(model_file)
    except ModelFileError as exc:
        _fail(str(exc))
    names, units = loaded.output_names, loaded.output_units
    if trials is not None and not 2 <= trials <= MAX_VALUES // len(names):
        raise ResourceLimitError(
            f"--trials {trials}: give 2 to {MAX_VALUES // len(names)} trials for "
            f"{len(names)} output(s) (every value is kept for the coverage intervals)"
        )
    document: dict = {
        "kind": RESULT_KIND,
        "version": RESULT_VERSION,
        "model": loaded.name,
        "source": str(model_file),
        "method": method.value,
        "p": p,
    }
    g = r = report = None
    try:
        if method in (Method.guf, Method.both):
            g = guf(loaded.model, loaded.inputs, p=p)
            document["guf"] = {**g.to_dict(), "outputs": _guf_outputs(g)}
        if method in (Method.mcm, Method.both):
            r = _run_mcm(
                loaded,
                trials=trials,
                adaptive=adaptive,
                digits=digits,
                seed=seed,
                p=p,
                executor=executor,
            )
            if r.converged is False:
                raise ConvergenceError(
                    f"{model_file}: adaptive Monte Carlo did not reach the tolerance of "
                    f"{digits} significant digit(s) within {r.trials} trials; ask for fewer "
                    "--digits or run a fixed number of --trials"
                )
            document["mcm"] = {**r.to_dict(), "outputs": _mcm_outputs(r, names, units)}
        if g is not None and r is not None:
            report = _validate(g, r, digits, names)
            document["validation"] = report.to_dict()
    except (ValueError, TypeError) as exc:
        _fail(f"{model_file}: {exc}")
    document["outputs"] = document["mcm" if r is not None else "guf"]["outputs"]

    if as_json:
        typer.echo(json.dumps(document, indent=2, allow_nan=False))
        return
    console = Console()
    title = loaded.name or str(model_file)
    console.print(f"[bold]{title}[/bold]  ({model_file})")
    if g is not None:
        for j in range(len(names)):
            console.print(_budget_table(g, j))
        console.print(
            _results_table(f"GUF results, p = {p}", document["guf"]["outputs"], extra="dof")
        )
        if len(names) > 1:
            console.print(
                f"hyper-ellipsoid k_p = {g.region_coverage_factor:.3f}, "
                f"λ_max = {g.largest_eigenvalue:.3f}"
            )
    if r is not None:
        console.print(
            _results_table(
                f"Monte Carlo results, p = {p} ({r.trials} trials)",
                document["mcm"]["outputs"],
                extra="shortest interval",
            )
        )
        console.print(r.message)
    if report is not None:
        console.print(report.to_rich())
        verdict = "GUF validated" if report.passed else "GUF NOT validated"
        console.print(f"[bold]{verdict}[/bold] by Monte Carlo ({report.procedure})")
