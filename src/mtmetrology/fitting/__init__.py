"""Geometric elements and their fits: least squares, batched least squares, probe-tip
compensation and the feature interface of the uncertainty engine."""

from mtmetrology.fitting.batch import (
    BatchLineFit,
    BatchPlaneFit,
    BatchRoundFit,
    fit_circles,
    fit_lines,
    fit_planes,
    fit_spheres,
)
from mtmetrology.fitting.composite import CombinedFeature, PointCoordinates
from mtmetrology.fitting.elements import Circle, Cone, Cylinder, Element, Line, Plane, Sphere
from mtmetrology.fitting.features import (
    BallCentre,
    CircleDiameter,
    Feature,
    Flatness,
    GaugeLength,
    Roundness,
    SphereDiameter,
    Sphericity,
)
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
from mtmetrology.fitting.probe import (
    TipCalibration,
    compensate,
    compensate_points,
    effective_tip_diameter,
    surface_normals,
)

__all__ = [
    "BallCentre",
    "BatchLineFit",
    "BatchPlaneFit",
    "BatchRoundFit",
    "Circle",
    "CircleDiameter",
    "CombinedFeature",
    "Cone",
    "Cylinder",
    "Element",
    "Feature",
    "FitError",
    "FitResult",
    "Flatness",
    "GaugeLength",
    "Line",
    "Plane",
    "PointCoordinates",
    "Roundness",
    "Sphere",
    "SphereDiameter",
    "Sphericity",
    "TipCalibration",
    "compensate",
    "compensate_points",
    "effective_tip_diameter",
    "fit_circle",
    "fit_circles",
    "fit_cone",
    "fit_cylinder",
    "fit_line",
    "fit_lines",
    "fit_plane",
    "fit_planes",
    "fit_sphere",
    "fit_spheres",
    "surface_normals",
]
