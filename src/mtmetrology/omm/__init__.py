"""On-machine measurement (OMM): probing repeatability, reference values, task uncertainty."""

from mtmetrology.omm.long_term import long_term_parameters
from mtmetrology.omm.pooling import PoolingResult, pooling_experiment
from mtmetrology.omm.reference import (
    ReferenceValue,
    coverage_probability,
    thermal_reference_value,
)
from mtmetrology.omm.repeatability import (
    RepeatabilityModel,
    TargetStatistics,
    fit_repeatability_model,
    lateral_deviation_threshold,
    normal_tangential,
    sphere_normal,
    target_statistics,
)
from mtmetrology.omm.repeatability_file import load_repeatability_model

__all__ = [
    "PoolingResult",
    "ReferenceValue",
    "RepeatabilityModel",
    "TargetStatistics",
    "coverage_probability",
    "fit_repeatability_model",
    "lateral_deviation_threshold",
    "load_repeatability_model",
    "long_term_parameters",
    "normal_tangential",
    "pooling_experiment",
    "sphere_normal",
    "target_statistics",
    "thermal_reference_value",
]
