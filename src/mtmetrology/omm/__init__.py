"""On-machine measurement (OMM): probing repeatability, reference values, task uncertainty."""

from mtmetrology.omm.repeatability import (
    RepeatabilityModel,
    TargetStatistics,
    fit_repeatability_model,
    lateral_deviation_threshold,
    normal_tangential,
    sphere_normal,
    target_statistics,
)

__all__ = [
    "RepeatabilityModel",
    "TargetStatistics",
    "fit_repeatability_model",
    "lateral_deviation_threshold",
    "normal_tangential",
    "sphere_normal",
    "target_statistics",
]
