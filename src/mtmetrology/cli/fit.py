"""``mtm fit``: geometric elements from point sets.

Points are read from a CSV file with columns ``x, y, z`` in mm (stylus-centre positions
when ``--tip-radius`` is given). The element is fitted by least squares or by one of the
Chebyshev criteria of :mod:`mtmetrology.fitting.minimum_zone`; the parameters, residual
statistics and form error are printed, or with ``--json`` a ``fit-result`` document.

The workflow, including the probe-tip compensation, is
:func:`mtmetrology.fitting.element_fit.fit_points_file`; this module parses and prints.
"""

from __future__ import annotations

import enum
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table as RichTable

from mtmetrology.cli._common import ReportOption, command_line, emit_result

__all__ = ["ElementName", "Method", "fit"]


class ElementName(enum.StrEnum):
    """The geometric elements ``mtm fit`` knows."""

    line = "line"
    plane = "plane"
    circle = "circle"
    sphere = "sphere"
    cylinder = "cylinder"
    cone = "cone"


class Method(enum.StrEnum):
    """Fitting criteria: least squares, minimum zone (Chebyshev), inscribed, circumscribed."""

    ls = "ls"
    minimum_zone = "minimum-zone"
    inscribed = "inscribed"
    circumscribed = "circumscribed"


def _print(console: Console, document: dict) -> None:
    """The fit, every number to the second significant digit of the residual rms
    (:func:`mtmetrology.formatting.format_fitted`)."""
    from mtmetrology.formatting import format_fitted

    res = document["residuals"]
    rms = res["rms"]

    def um(value: float) -> str:
        return format_fitted(value, "µm", rms)

    title = f"{document['element']} ({document['method']}) from {document['source']}"
    table = RichTable(title=title)
    table.add_column("parameter")
    table.add_column("value", justify="right")
    table.add_column("unit")
    for row in document["parameters"]:
        table.add_row(row["name"], format_fitted(row["value"], row["unit"], rms), row["unit"])
    console.print(table)
    console.print(
        f"residuals: n = {res['n']}, rms = {um(rms)} µm, "
        f"min = {um(res['min'])} µm, max = {um(res['max'])} µm"
    )
    form = document["form_error"]
    console.print(f"{form['name']} ({document['method']}): {um(form['value'])} µm")
    if "least_squares_form_error" in document:
        ls = document["least_squares_form_error"]
        console.print(f"{form['name']} (least-squares peak-to-valley): {um(ls['value'])} µm")
    if "zone" in document:
        zone = document["zone"]
        console.print(
            f"zone bounds: {format_fitted(zone['low'], 'mm', rms)} mm to "
            f"{format_fitted(zone['high'], 'mm', rms)} mm"
        )
        lines = ", ".join(str(line) for line in document["contact_lines"])
        console.print(f"contact points (CSV lines): {lines}")
    for note in document.get("notes", []):
        console.print(f"note: {note}")
    console.print(document["message"])


def fit(
    ctx: typer.Context,
    element: Annotated[ElementName, typer.Argument(help="The element to fit.")],
    points_csv: Annotated[
        Path,
        typer.Argument(
            help="CSV file with columns x, y, z (mm), one point a row; x, y alone: a line or "
            "circle profile in the plane z = 0."
        ),
    ],
    method: Annotated[
        Method,
        typer.Option(
            "--method",
            help="ls (least squares), minimum-zone (Chebyshev), inscribed or circumscribed.",
        ),
    ] = Method.ls,
    tip_radius: Annotated[
        float | None,
        typer.Option(
            "--tip-radius",
            help="Stylus tip radius, mm: the points are tip centres; the element is offset.",
        ),
    ] = None,
    inside: Annotated[
        bool,
        typer.Option(
            "--inside",
            help="Internal feature (bore, ring, female cone): the tip offset enlarges it.",
        ),
    ] = False,
    json_output: Annotated[
        bool, typer.Option("--json", help="Print a fit-result JSON document.")
    ] = False,
    report_path: ReportOption = None,
) -> None:
    """Fit a line, plane, circle, sphere, cylinder or cone to points and report its form.

    A line whose points all have the same z is a profile in that plane (2-D straightness);
    otherwise its minimum zone is the smallest enclosing cylinder (ISO 12780-1). A file of
    x, y alone is a line or circle profile in the plane z = 0 (2-D straightness or
    roundness, stated in a note).
    """
    from mtmetrology.fitting.element_fit import fit_points_file

    result = fit_points_file(
        element.value, points_csv, method=method.value, tip_radius=tip_radius, inside=inside
    )
    document = result.to_dict()
    report = None
    if report_path is not None:
        from mtmetrology.report import Report
        from mtmetrology.report.results import add_fit_document

        rep = Report(
            f"{element.value.capitalize()} fit: {points_csv.name}",
            command=command_line(ctx),
            provenance={"inputs": [points_csv]},
        )
        report = add_fit_document(rep, document, result.residuals, result.points)
    emit_result(
        document,
        lambda: _print(Console(), document),
        output=None,
        report=report,
        report_path=report_path,
        as_json=json_output,
    )
