"""``mtm uncertainty``: measurement-model files through GUF and Monte Carlo.

``mtm uncertainty run MODEL.yaml --method guf|mcm|both`` prints the uncertainty
budget, the estimates with u, U, k and coverage intervals and, when both methods
ran, the validation of the GUF by Monte Carlo (JCGM 101 §8, JCGM 102 §8).
``--json`` prints the result document of
:func:`mtmetrology.uncertainty.outputs.result_document` instead::

    {"kind": "uncertainty-result", "version": 2, "method": "both",
     "outputs": [{name, value, unit, u, U, k, p, interval}],
     "guf": {...}, "mcm": {...}, "validation": {...}}

This module only parses options and prints: the results, their ``outputs`` and the
document come from the library.
"""

from __future__ import annotations

import math
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.table import Table

from mtmetrology.cli._common import ReportOption, command_line, emit_result, fail
from mtmetrology.cli._progress import progress_bar
from mtmetrology.errors import MtmetrologyError, ResourceLimitError

if TYPE_CHECKING:
    from mtmetrology.uncertainty.guf import GUFResult
    from mtmetrology.uncertainty.outputs import Output

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


def _budget_table(r: GUFResult, j: int) -> Table:
    """The budget of output j as the HTML report shows it (display units, one share)."""
    from mtmetrology.formatting import SHARE_DEFINITION, budget_cells, budget_columns
    from mtmetrology.units import display_unit

    name = r.names[j]
    unit = display_unit(r.units[j]) if r.units[j] else ""
    table = Table(
        title=f"Uncertainty budget of {name}" + (f" in {unit}" if unit else "") + " (GUF)",
        caption=SHARE_DEFINITION,
    )
    for col in budget_columns(name):
        table.add_column(col, justify="left" if col in ("input", "unit") else "right")
    for cells in budget_cells(r.budget(j), r.units[j])[0]:
        table.add_row(*cells)
    return table


def _results_table(title: str, outputs: tuple[Output, ...], extra: dict | None = None) -> Table:
    """One row per output; ``extra`` = {column: [cell per output]}."""
    from mtmetrology.formatting import format_uncertainty, format_value

    table = Table(title=title)
    for col in ("output", "value", "u", "U", "k", "interval", "unit", *(extra or {})):
        table.add_column(col, justify="left" if col in ("output", "unit") else "right")
    for j, o in enumerate(outputs):
        cells = [
            o.name,
            format_value(o.value, o.u),
            format_uncertainty(o.u),
            format_uncertainty(o.U),
            "-" if o.k is None else f"{o.k:.3f}",
            f"[{format_value(o.interval[0], o.u)}, {format_value(o.interval[1], o.u)}]",
            o.unit,
            *(column[j] for column in (extra or {}).values()),
        ]
        table.add_row(*cells)
    return table


def _report(evaluation, model_file: Path, command, *, seed):
    """The HTML report: validation, GUF budget, Monte Carlo histograms against the GUF."""
    from mtmetrology.report import Report
    from mtmetrology.report.results import add_result

    provenance = {"inputs": [model_file], "seed": "none (fresh entropy)" if seed is None else seed}
    rep = Report(
        f"Measurement uncertainty: {evaluation.model or model_file.name}",
        command=command,
        provenance=provenance,
    )
    return add_result(rep, evaluation)


@app.command("run")
def run(
    ctx: typer.Context,
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
    report_path: ReportOption = None,
) -> None:
    """Evaluate a measurement model by GUF, Monte Carlo, or both (with validation)."""
    from mtmetrology.formatting import format_value
    from mtmetrology.uncertainty.evaluation import evaluate_model
    from mtmetrology.uncertainty.modelfile import ModelFileError, load_model

    try:
        loaded = load_model(model_file)
    except ModelFileError as exc:
        _fail(str(exc))
    try:
        with progress_bar("Monte Carlo trials") as progress:
            evaluation = evaluate_model(
                loaded,
                method.value,
                digits=digits,
                p=p,
                trials=trials,
                adaptive=adaptive,
                seed=seed,
                executor=executor,
                source=str(model_file),
                progress=progress,
            )
    except ResourceLimitError:
        raise
    except (MtmetrologyError, ValueError, TypeError) as exc:
        _fail(f"{model_file}: {exc}")
    g, r, report = evaluation.guf, evaluation.mcm, evaluation.validation

    html = None
    if report_path is not None:
        html = _report(evaluation, model_file, command_line(ctx), seed=seed)

    def summary() -> None:
        console = Console()
        title = loaded.name or str(model_file)
        console.print(f"[bold]{title}[/bold]  ({model_file})")
        if g is not None:
            for j in range(len(g.names)):
                console.print(_budget_table(g, j))
            dof = ["inf" if math.isinf(v) else f"{v:.1f}" for v in g.dof_effective]
            console.print(_results_table(f"GUF results, p = {p}", g.outputs, {"dof": dof}))
            if len(g.names) > 1:
                console.print(
                    f"hyper-ellipsoid k_p = {g.region_coverage_factor:.3f}, "
                    f"λ_max = {g.largest_eigenvalue:.3f}"
                )
        if r is not None:
            shortest = [
                f"[{format_value(low, o.u)}, {format_value(high, o.u)}]"
                for (low, high), o in zip(r.interval_shortest, r.outputs, strict=True)
            ]
            console.print(
                _results_table(
                    f"Monte Carlo results, p = {p} ({r.trials} trials)",
                    r.outputs,
                    {"shortest interval": shortest},
                )
            )
            console.print(r.message)
        if report is not None:
            console.print(report.to_rich())
            verdict = "GUF validated" if report.passed else "GUF NOT validated"
            console.print(f"[bold]{verdict}[/bold] by Monte Carlo ({report.procedure})")

    emit_result(
        evaluation.to_dict(),
        summary,
        output=None,
        report=html,
        report_path=report_path,
        as_json=as_json,
    )
