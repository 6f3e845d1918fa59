"""The ``fit-result`` document: what ``mtm fit --json`` prints, built in the library.

A library user gets the same JSON as the command line::

    {"kind": "fit-result", "version": 1, "source": "ring.csv", "element": "circle",
     "method": "ls", "parameters": [{name, value, unit}], "residuals": {n, rms, min, max,
     unit}, "form_error": {name, value, unit}, ...}

Positions and radii are in mm, direction cosines dimensionless, the cone half-angle in
degrees, residuals and form errors in µm (conversions through :mod:`mtmetrology.units`).
"""

from __future__ import annotations

import math

import numpy as np

from mtmetrology.units import from_internal

__all__ = ["FORM_NAMES", "RESULT_KIND", "RESULT_VERSION", "element_parameters", "fit_document"]

RESULT_KIND = "fit-result"
RESULT_VERSION = 1

#: The form error each element's fit reports (ISO 12780, 12781, 12181, 12180 ...).
FORM_NAMES = {
    "line": "straightness",
    "plane": "flatness",
    "circle": "roundness",
    "sphere": "sphericity",
    "cylinder": "cylindricity",
    "cone": "conicity",
}

_DIMENSIONLESS = ("ax", "ay", "az", "nx", "ny", "nz")


def element_parameters(element) -> list[dict]:
    """Element parameters with their units: positions and radii mm, angles deg."""
    rows = []
    for name, value in zip(element.parameter_names, element.parameters, strict=True):
        if name == "half_angle":
            rows.append({"name": name, "value": float(from_internal(value, "deg")), "unit": "deg"})
        elif name in _DIMENSIONLESS:
            rows.append({"name": name, "value": float(value), "unit": "1"})
        else:
            rows.append({"name": name, "value": float(value), "unit": "mm"})
    return rows


def _um(value: float) -> float:
    return float(from_internal(value, "µm"))


def fit_document(
    element_name: str,
    method: str,
    source: str,
    element,
    residuals: np.ndarray,
    form_error: float,
    extra: dict | None = None,
) -> dict:
    """The ``fit-result`` document of a fitted element.

    Parameters
    ----------
    element_name : str
        ``line``, ``plane``, ``circle``, ``sphere``, ``cylinder`` or ``cone``.
    method : str
        ``ls``, ``minimum-zone``, ``inscribed`` or ``circumscribed``.
    source : str
        Where the points came from.
    element : Element
        The reported element (after probe compensation when it applied), mm and rad.
    residuals : (n,) ndarray, mm
    form_error : float, mm
    extra : dict, optional
        Further entries (status, zone, contact lines, tip radius, notes).
    """
    return {
        "kind": RESULT_KIND,
        "version": RESULT_VERSION,
        "source": str(source),
        "element": element_name,
        "method": method,
        "parameters": element_parameters(element),
        "residuals": {
            "n": len(residuals),
            "rms": _um(math.sqrt(float(np.mean(residuals**2)))),
            "min": _um(float(residuals.min())),
            "max": _um(float(residuals.max())),
            "unit": "µm",
        },
        "form_error": {"name": FORM_NAMES[element_name], "value": _um(form_error), "unit": "µm"},
        **(extra or {}),
    }
