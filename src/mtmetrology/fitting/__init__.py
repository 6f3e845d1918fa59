"""Geometric elements and their fits: least squares, batched least squares, probe-tip
compensation and the feature interface of the uncertainty engine."""

from mtmetrology.fitting.elements import Circle, Cone, Cylinder, Element, Line, Plane, Sphere
from mtmetrology.fitting.least_squares import (
    FitError,
    FitResult,
    fit_circle,
    fit_cone,
    fit_cylinder,
    fit_line,
    fit_plane,
    fit_sphere,
)

__all__ = [
    "Circle",
    "Cone",
    "Cylinder",
    "Element",
    "FitError",
    "FitResult",
    "Line",
    "Plane",
    "Sphere",
    "fit_circle",
    "fit_cone",
    "fit_cylinder",
    "fit_line",
    "fit_plane",
    "fit_sphere",
]
