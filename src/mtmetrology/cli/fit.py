"""``mtm fit``: geometric elements from point sets.

Points are read from a CSV file with columns ``x, y, z`` in mm (stylus-centre positions
when ``--tip-radius`` is given). The element is fitted by least squares or by one of the
Chebyshev criteria of :mod:`mtmetrology.fitting.minimum_zone`; the parameters, residual
statistics and form error are printed, or with ``--json`` a ``fit-result`` document.

Probe-tip compensation offsets the fitted element along its surface normal by the tip
radius, towards the material: the radius of a shaft, ball or male cone shrinks by
``r_tip`` (``R - r_tip``), that of a bore, ring or female cone (``--inside``) grows
(``R + r_tip``); a cone keeps its half-angle and its apex moves along the axis by
``r_tip / sin(psi)``. Residuals and form errors are unchanged by the offset. A plane or a
line carries no material side in ``x, y, z`` alone, so its position is reported for the
stylus centre and the output says so.
"""

from __future__ import annotations

import enum
import json
import math
from pathlib import Path
from typing import Annotated

import numpy as np
import typer
from rich.console import Console
from rich.table import Table as RichTable

from mtmetrology._memory import release_free_memory
from mtmetrology.cli._common import ReportOption, command_line, write_report
from mtmetrology.errors import InputError
from mtmetrology.fitting.documents import fit_document
from mtmetrology.fitting.elements import Circle, Cone, Cylinder, Line, Sphere
from mtmetrology.fitting.least_squares import (
    FitResult,
    fit_circle,
    fit_cone,
    fit_cylinder,
    fit_line,
    fit_plane,
    fit_sphere,
)
from mtmetrology.fitting.probe import compensate
from mtmetrology.io import read_csv_table
from mtmetrology.units import from_internal

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


_LEAST_SQUARES = {
    ElementName.plane: fit_plane,
    ElementName.circle: fit_circle,
    ElementName.sphere: fit_sphere,
    ElementName.cylinder: fit_cylinder,
    ElementName.cone: fit_cone,
}

#: The Chebyshev fits, by name in :mod:`mtmetrology.fitting.minimum_zone` (imported only
#: when one is asked for: it brings scipy.optimize and scipy.spatial, which a
#: least-squares fit to millions of points does without).
_ZONE_FITS = {
    (ElementName.plane, Method.minimum_zone): "flatness",
    (ElementName.circle, Method.minimum_zone): "roundness",
    (ElementName.circle, Method.inscribed): "inscribed_circle",
    (ElementName.circle, Method.circumscribed): "circumscribed_circle",
    (ElementName.sphere, Method.minimum_zone): "sphericity",
    (ElementName.sphere, Method.inscribed): "inscribed_sphere",
    (ElementName.sphere, Method.circumscribed): "circumscribed_sphere",
    (ElementName.cylinder, Method.minimum_zone): "cylindricity",
    (ElementName.cylinder, Method.inscribed): "inscribed_cylinder",
    (ElementName.cylinder, Method.circumscribed): "circumscribed_cylinder",
}


class _UsageError(ValueError):
    """A request ``mtm fit`` cannot serve (element and method that do not combine, ...)."""


def _read_points(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Points (n, 3) in mm and the file line of each."""
    table = read_csv_table(path, required=["x", "y", "z"])
    points, lines = np.c_[table.floats("x"), table.floats("y"), table.floats("z")], table.lines
    del table
    # Arrow's allocator keeps the freed text columns (about 3 bytes per byte of the file)
    # for reuse, glibc the reader's freed scratch; nothing else uses Arrow here, so return
    # them before the fit's own peak.
    release_free_memory()
    return points, lines


def _line_in_plane(points: np.ndarray) -> bool:
    """A profile whose z is constant is a line in the plane z = z0 (2-D straightness)."""
    return bool(np.all(points[:, 2] == points[0, 2]))


def _least_squares(element: ElementName, points: np.ndarray) -> tuple[Line, FitResult]:
    """The least-squares element and its fit (a line in the plane z = z0 lifted to 3-D)."""
    if element is ElementName.line and _line_in_plane(points):
        result = fit_line(points[:, :2])
        line = result.element
        return Line(np.r_[line.point, points[0, 2]], np.r_[line.direction, 0.0]), result
    fit = fit_line if element is ElementName.line else _LEAST_SQUARES[element]
    result = fit(points)
    return result.element, result


def _zone_fit(element: ElementName, method: Method, points: np.ndarray):
    from mtmetrology.fitting import minimum_zone

    if element is ElementName.line and method is Method.minimum_zone:
        normal = (0.0, 0.0, 1.0) if _line_in_plane(points) else None
        return minimum_zone.straightness(points, plane_normal=normal)
    try:
        name = _ZONE_FITS[element, method]
    except KeyError:
        raise _UsageError(
            f"--method {method.value} is not available for a {element.value}: "
            + (
                "minimum-zone, inscribed and circumscribed apply to circle, sphere and "
                "cylinder, minimum-zone also to line and plane"
            )
        ) from None
    return getattr(minimum_zone, name)(points)


def _compensate(element, tip_radius: float, inside: bool):
    """The element offset by the tip radius towards the material (module notes): round
    elements and cones through :func:`mtmetrology.fitting.probe.compensate`; a plane or a
    line carries no material side in x, y, z alone and is returned as fitted."""
    if isinstance(element, Circle | Sphere | Cylinder | Cone):
        return compensate(element, tip_radius, inside)
    return element


def _print(console: Console, document: dict) -> None:
    title = f"{document['element']} ({document['method']}) from {document['source']}"
    table = RichTable(title=title)
    table.add_column("parameter")
    table.add_column("value", justify="right")
    table.add_column("unit")
    for row in document["parameters"]:
        table.add_row(row["name"], f"{row['value']:.6f}", row["unit"])
    console.print(table)
    res = document["residuals"]
    console.print(
        f"residuals: n = {res['n']}, rms = {res['rms']:.3f} µm, "
        f"min = {res['min']:.3f} µm, max = {res['max']:.3f} µm"
    )
    form = document["form_error"]
    console.print(f"{form['name']} ({document['method']}): {form['value']:.3f} µm")
    if "least_squares_form_error" in document:
        ls = document["least_squares_form_error"]
        console.print(f"{form['name']} (least-squares peak-to-valley): {ls['value']:.3f} µm")
    if "zone" in document:
        zone = document["zone"]
        console.print(f"zone bounds: {zone['low']:.6f} mm to {zone['high']:.6f} mm")
        lines = ", ".join(str(line) for line in document["contact_lines"])
        console.print(f"contact points (CSV lines): {lines}")
    for note in document.get("notes", []):
        console.print(f"note: {note}")
    console.print(document["message"])


def fit(
    ctx: typer.Context,
    element: Annotated[ElementName, typer.Argument(help="The element to fit.")],
    points_csv: Annotated[
        Path, typer.Argument(help="CSV file with columns x, y, z (mm), one point a row.")
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
    otherwise its minimum zone is the smallest enclosing cylinder (ISO 12780-1).
    """
    try:
        if tip_radius is not None and not (math.isfinite(tip_radius) and tip_radius >= 0.0):
            raise _UsageError(f"--tip-radius must be a finite length >= 0 mm, got {tip_radius}")
        points, lines = _read_points(points_csv)
        extra: dict = {}
        notes: list[str] = []
        if method is Method.ls:
            fitted, result = _least_squares(element, points)
            residuals, form_error = result.residuals, result.form_error
            extra.update(
                status=result.status,
                success=result.success,
                nit=result.nit,
                message=result.message,
            )
        else:
            zone = _zone_fit(element, method, points)
            fitted, residuals, form_error = zone.element, zone.residuals, zone.form_error
            extra.update(
                least_squares_form_error={
                    "value": float(from_internal(zone.least_squares_form_error, "µm")),
                    "unit": "µm",
                },
                zone={"low": zone.bounds[0], "high": zone.bounds[1], "unit": "mm"},
                contact_lines=[int(line) for line in lines[zone.contacts]],
                nit=zone.iterations,
                success=zone.converged,
                message=zone.message,
            )
        if tip_radius is not None:
            compensated = _compensate(fitted, tip_radius, inside)
            if compensated is fitted:
                notes.append(
                    f"a {element.value} has no material side in x, y, z: its position is "
                    "that of the stylus centre (not offset by the tip radius)"
                )
            elif "zone" in extra and isinstance(fitted, Circle | Sphere | Cylinder):
                offset = compensated.radius - fitted.radius
                extra["zone"].update(low=zone.bounds[0] + offset, high=zone.bounds[1] + offset)
            fitted = compensated
            extra["tip_radius"] = {"value": tip_radius, "unit": "mm", "inside": inside}
        if notes:
            extra["notes"] = notes
    except ValueError as exc:  # InputFileError, FitError, _UsageError, element checks
        message = str(exc)
        if not isinstance(exc, _UsageError) and str(points_csv) not in message:
            message = f"{points_csv}: {message}"  # name the file the points came from
        raise InputError(message) from None
    document = fit_document(
        element.value, method.value, str(points_csv), fitted, residuals, form_error, extra
    )
    if report_path is not None:
        from mtmetrology.report import Report
        from mtmetrology.report.results import add_fit_document

        rep = Report(
            f"{element.value.capitalize()} fit: {points_csv.name}",
            command=command_line(ctx),
            provenance={"inputs": [points_csv]},
        )
        write_report(add_fit_document(rep, document, residuals, points), report_path)
    if json_output:
        typer.echo(json.dumps(document, indent=2, allow_nan=False, ensure_ascii=False))
    else:
        _print(Console(), document)
