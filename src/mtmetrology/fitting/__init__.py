"""Geometric elements and their fits: least squares, batched least squares, probe-tip
compensation and the features (least-squares and minimum-zone) of the uncertainty
engine.

The names load on first use (PEP 562): importing one module of the package does not
import the others.
"""

from typing import TYPE_CHECKING

from mtmetrology._lazy import lazy_exports

#: Public name -> module that defines it (loaded on first use, PEP 562).
_EXPORTS = {
    "BatchLineFit": "mtmetrology.fitting.batch",
    "BatchPlaneFit": "mtmetrology.fitting.batch",
    "BatchRoundFit": "mtmetrology.fitting.batch",
    "fit_circles": "mtmetrology.fitting.batch",
    "fit_lines": "mtmetrology.fitting.batch",
    "fit_planes": "mtmetrology.fitting.batch",
    "fit_spheres": "mtmetrology.fitting.batch",
    "BatchCylinderFit": "mtmetrology.fitting.batch_cylinders",
    "fit_cylinders": "mtmetrology.fitting.batch_cylinders",
    "CombinedFeature": "mtmetrology.fitting.composite",
    "PointCoordinates": "mtmetrology.fitting.composite",
    "Circle": "mtmetrology.fitting.elements",
    "Cone": "mtmetrology.fitting.elements",
    "Cylinder": "mtmetrology.fitting.elements",
    "Element": "mtmetrology.fitting.elements",
    "Line": "mtmetrology.fitting.elements",
    "Plane": "mtmetrology.fitting.elements",
    "Sphere": "mtmetrology.fitting.elements",
    "BallCentre": "mtmetrology.fitting.features",
    "CircleCentre": "mtmetrology.fitting.features",
    "CircleDiameter": "mtmetrology.fitting.features",
    "CylinderDiameter": "mtmetrology.fitting.features",
    "Cylindricity": "mtmetrology.fitting.features",
    "Feature": "mtmetrology.fitting.features",
    "Flatness": "mtmetrology.fitting.features",
    "GaugeLength": "mtmetrology.fitting.features",
    "Roundness": "mtmetrology.fitting.features",
    "SphereDiameter": "mtmetrology.fitting.features",
    "Sphericity": "mtmetrology.fitting.features",
    "FitError": "mtmetrology.fitting.least_squares",
    "FitResult": "mtmetrology.fitting.least_squares",
    "fit_circle": "mtmetrology.fitting.least_squares",
    "fit_cone": "mtmetrology.fitting.least_squares",
    "fit_cylinder": "mtmetrology.fitting.least_squares",
    "fit_line": "mtmetrology.fitting.least_squares",
    "fit_plane": "mtmetrology.fitting.least_squares",
    "fit_sphere": "mtmetrology.fitting.least_squares",
    "TipCalibration": "mtmetrology.fitting.probe",
    "compensate": "mtmetrology.fitting.probe",
    "compensate_points": "mtmetrology.fitting.probe",
    "effective_tip_diameter": "mtmetrology.fitting.probe",
    "surface_normals": "mtmetrology.fitting.probe",
    "MinimumZoneCylinderDiameter": "mtmetrology.fitting.zone_features",
    "MinimumZoneCylindricity": "mtmetrology.fitting.zone_features",
    "MinimumZoneFlatness": "mtmetrology.fitting.zone_features",
    "MinimumZoneRoundness": "mtmetrology.fitting.zone_features",
    "MinimumZoneSphereDiameter": "mtmetrology.fitting.zone_features",
    "MinimumZoneSphericity": "mtmetrology.fitting.zone_features",
}

if TYPE_CHECKING:
    from mtmetrology.fitting.batch import (
        BatchLineFit,
        BatchPlaneFit,
        BatchRoundFit,
        fit_circles,
        fit_lines,
        fit_planes,
        fit_spheres,
    )
    from mtmetrology.fitting.batch_cylinders import BatchCylinderFit, fit_cylinders
    from mtmetrology.fitting.composite import CombinedFeature, PointCoordinates
    from mtmetrology.fitting.elements import Circle, Cone, Cylinder, Element, Line, Plane, Sphere
    from mtmetrology.fitting.features import (
        BallCentre,
        CircleCentre,
        CircleDiameter,
        CylinderDiameter,
        Cylindricity,
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
    from mtmetrology.fitting.zone_features import (
        MinimumZoneCylinderDiameter,
        MinimumZoneCylindricity,
        MinimumZoneFlatness,
        MinimumZoneRoundness,
        MinimumZoneSphereDiameter,
        MinimumZoneSphericity,
    )

__all__ = [
    "BallCentre",
    "BatchCylinderFit",
    "BatchLineFit",
    "BatchPlaneFit",
    "BatchRoundFit",
    "Circle",
    "CircleCentre",
    "CircleDiameter",
    "CombinedFeature",
    "Cone",
    "Cylinder",
    "CylinderDiameter",
    "Cylindricity",
    "Element",
    "Feature",
    "FitError",
    "FitResult",
    "Flatness",
    "GaugeLength",
    "Line",
    "MinimumZoneCylinderDiameter",
    "MinimumZoneCylindricity",
    "MinimumZoneFlatness",
    "MinimumZoneRoundness",
    "MinimumZoneSphereDiameter",
    "MinimumZoneSphericity",
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
    "fit_cylinders",
    "fit_line",
    "fit_lines",
    "fit_plane",
    "fit_planes",
    "fit_sphere",
    "fit_spheres",
    "surface_normals",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
