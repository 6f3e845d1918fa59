"""One ``mtm fit`` request as a library call: :func:`fit_points_file`.

Points are read from a CSV file with columns ``x, y, z`` in mm (stylus-centre positions
when ``tip_radius`` is given). The element is fitted by least squares or by one of the
Chebyshev criteria of :mod:`mtmetrology.fitting.minimum_zone`; :class:`ElementFit` holds
the element, residuals and form error and gives the ``fit-result`` document
(:func:`~mtmetrology.fitting.documents.fit_document`).

Probe-tip compensation offsets the fitted element along its surface normal by the tip
radius, towards the material: the radius of a shaft, ball or male cone shrinks by
``r_tip`` (``R - r_tip``), that of a bore, ring or female cone (``inside``) grows
(``R + r_tip``); a cone keeps its half-angle and its apex moves along the axis by
``r_tip / sin(psi)``. Residuals and form errors are unchanged by the offset; the minimum
zone's bounds (radii) move with the radius. A plane or a line carries no material side in
``x, y, z`` alone, so its position is reported for the stylus centre, with a note.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mtmetrology._memory import release_free_memory
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

__all__ = ["ELEMENTS", "METHODS", "PROFILE_ELEMENTS", "ElementFit", "fit_points_file"]

#: The elements and the criteria of :func:`fit_points_file`.
ELEMENTS = ("line", "plane", "circle", "sphere", "cylinder", "cone")
#: The elements a profile in a plane describes: a file of ``x, y`` alone is read in z = 0.
PROFILE_ELEMENTS = ("line", "circle")
METHODS = ("ls", "minimum-zone", "inscribed", "circumscribed")

_LEAST_SQUARES = {
    "plane": fit_plane,
    "circle": fit_circle,
    "sphere": fit_sphere,
    "cylinder": fit_cylinder,
    "cone": fit_cone,
}

#: The Chebyshev fits, by name in :mod:`mtmetrology.fitting.minimum_zone` (imported only
#: when one is asked for: it brings scipy.optimize and scipy.spatial, which a
#: least-squares fit to millions of points does without).
_ZONE_FITS = {
    ("plane", "minimum-zone"): "flatness",
    ("circle", "minimum-zone"): "roundness",
    ("circle", "inscribed"): "inscribed_circle",
    ("circle", "circumscribed"): "circumscribed_circle",
    ("sphere", "minimum-zone"): "sphericity",
    ("sphere", "inscribed"): "inscribed_sphere",
    ("sphere", "circumscribed"): "circumscribed_sphere",
    ("cylinder", "minimum-zone"): "cylindricity",
    ("cylinder", "inscribed"): "inscribed_cylinder",
    ("cylinder", "circumscribed"): "circumscribed_cylinder",
}


class _UsageError(ValueError):
    """A request that cannot be served (element and method that do not combine, ...)."""


@dataclass(frozen=True)
class ElementFit:
    """A fitted element with its residuals and form error (:func:`fit_points_file`).

    Attributes
    ----------
    element_name, method, source : str
    element : Element
        Fitted (and tip-compensated when a tip radius was given).
    residuals : (n,) ndarray, mm
    form_error : float, mm
    points : (n, 3) ndarray, mm
    extra : dict
        The further fields of the document (status, zone bounds, contact lines, notes).
    """

    element_name: str
    method: str
    source: str
    element: object
    residuals: np.ndarray
    form_error: float
    points: np.ndarray
    extra: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        """The ``fit-result`` document (:func:`~mtmetrology.fitting.documents.fit_document`)."""
        return fit_document(
            self.element_name,
            self.method,
            self.source,
            self.element,
            self.residuals,
            self.form_error,
            self.extra,
        )


def _read_points(path: Path, element: str) -> tuple[np.ndarray, np.ndarray, bool]:
    """Points (n, 3) in mm, the file line of each, and whether the file is a 2-D profile
    (columns ``x, y`` only: a line or circle in the plane z = 0)."""
    table = read_csv_table(path, required=["x", "y"])
    profile = not table.has("z") and element in PROFILE_ELEMENTS
    z = np.zeros(len(table)) if profile else table.floats("z")  # names the missing z
    points, lines = np.c_[table.floats("x"), table.floats("y"), z], table.lines
    del table
    # Arrow's allocator keeps the freed text columns (about 3 bytes per byte of the file)
    # for reuse, glibc the reader's freed scratch; return them before the fit's own peak.
    release_free_memory()
    return points, lines, profile


def _line_in_plane(points: np.ndarray) -> bool:
    """A profile whose z is constant is a line in the plane z = z0 (2-D straightness)."""
    return bool(np.all(points[:, 2] == points[0, 2]))


def _least_squares(element: str, points: np.ndarray) -> tuple[Line, FitResult]:
    """The least-squares element and its fit (a line in the plane z = z0 lifted to 3-D)."""
    if element == "line" and _line_in_plane(points):
        result = fit_line(points[:, :2])
        line = result.element
        return Line(np.r_[line.point, points[0, 2]], np.r_[line.direction, 0.0]), result
    fit = fit_line if element == "line" else _LEAST_SQUARES[element]
    result = fit(points)
    return result.element, result


def _zone_fit(element: str, method: str, points: np.ndarray):
    from mtmetrology.fitting import minimum_zone

    if element == "line" and method == "minimum-zone":
        normal = (0.0, 0.0, 1.0) if _line_in_plane(points) else None
        return minimum_zone.straightness(points, plane_normal=normal)
    try:
        name = _ZONE_FITS[element, method]
    except KeyError:
        raise _UsageError(
            f"--method {method} is not available for a {element}: "
            "minimum-zone, inscribed and circumscribed apply to circle, sphere and "
            "cylinder, minimum-zone also to line and plane"
        ) from None
    return getattr(minimum_zone, name)(points)


def fit_points_file(
    element: str,
    points_csv: str | Path,
    *,
    method: str = "ls",
    tip_radius: float | None = None,
    inside: bool = False,
) -> ElementFit:
    """Fit a line, plane, circle, sphere, cylinder or cone to the points of a CSV file.

    A line whose points all have the same z is a profile in that plane (2-D straightness,
    ISO 12780-1: the zone between two parallel lines); otherwise its minimum zone is the
    smallest enclosing cylinder. A file of ``x, y`` alone is a profile in the plane z = 0
    for a line or a circle (:data:`PROFILE_ELEMENTS`), stated in the document's notes.

    Parameters
    ----------
    element : str
        One of :data:`ELEMENTS`.
    points_csv : path
        Columns ``x, y, z`` in mm, one point a row (``x, y`` for a line or circle profile).
    method : str
        ``ls`` (least squares), ``minimum-zone`` (Chebyshev), ``inscribed`` or
        ``circumscribed``.
    tip_radius : float, optional
        Stylus tip radius, mm: the points are tip centres and the element is offset by it
        towards the material (module notes), R ∓ r_tip.
    inside : bool
        Internal feature (bore, ring, female cone): the tip offset enlarges it.

    Returns
    -------
    ElementFit

    Raises
    ------
    InputError
        A bad file, too few points, an element and method that do not combine, a tip
        radius that is not a finite length >= 0; the message names the file.

    References
    ----------
    ISO 12780-1, 12781-1, 12181-1, 12180-1 (form errors); Anthony et al. (1996) for the
    Chebyshev fits (:mod:`mtmetrology.fitting.minimum_zone`).
    """
    try:
        if tip_radius is not None and not (math.isfinite(tip_radius) and tip_radius >= 0.0):
            raise _UsageError(f"--tip-radius must be a finite length >= 0 mm, got {tip_radius}")
        if element not in ELEMENTS or method not in METHODS:
            raise _UsageError(f"unknown element {element!r} or method {method!r}")
        points, lines, profile = _read_points(Path(points_csv), element)
        extra: dict = {}
        if profile:
            form = "straightness" if element == "line" else "roundness"
            extra["notes"] = [f"x, y profile: fitted in the plane z = 0 (2-D {form})"]
        if method == "ls":
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
                status=zone.status,
                nit=zone.iterations,
                success=zone.success,
                message=zone.message,
            )
        if tip_radius is not None:
            note = None
            if isinstance(fitted, Circle | Sphere | Cylinder | Cone):
                compensated = compensate(fitted, tip_radius, inside)
                if "zone" in extra and not isinstance(fitted, Cone):
                    offset = compensated.radius - fitted.radius
                    extra["zone"].update(low=zone.bounds[0] + offset, high=zone.bounds[1] + offset)
                fitted = compensated
            else:
                note = (
                    f"a {element} has no material side in x, y, z: its position is "
                    "that of the stylus centre (not offset by the tip radius)"
                )
            extra["tip_radius"] = {"value": tip_radius, "unit": "mm", "inside": inside}
            if note is not None:
                extra.setdefault("notes", []).append(note)
    except ValueError as exc:  # InputFileError, FitError, _UsageError, element checks
        message = str(exc)
        if not isinstance(exc, _UsageError) and str(points_csv) not in message:
            message = f"{points_csv}: {message}"  # name the file the points came from
        raise InputError(message) from None
    return ElementFit(
        element, method, str(points_csv), fitted, residuals, form_error, points, extra
    )
