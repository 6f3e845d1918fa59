"""On-machine measurement (OMM): probing repeatability, reference values, task uncertainty."""

from mtmetrology.identification.long_term import long_term_parameters
from mtmetrology.omm.drift import detrend_cubic, sliding_window_std
from mtmetrology.omm.hysteresis import HysteresisResult, hysteresis_errors, radial_projection
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
from mtmetrology.omm.repeatability_windows import WindowStatistics, window_statistics
from mtmetrology.omm.simulator import TaskInputs, covariance_simulator
from mtmetrology.omm.task import TaskResult, task_uncertainty

__all__ = [
    "HysteresisResult",
    "PoolingResult",
    "ReferenceValue",
    "RepeatabilityModel",
    "TargetStatistics",
    "TaskInputs",
    "TaskResult",
    "WindowStatistics",
    "covariance_simulator",
    "coverage_probability",
    "detrend_cubic",
    "fit_repeatability_model",
    "hysteresis_errors",
    "lateral_deviation_threshold",
    "load_repeatability_model",
    "long_term_parameters",
    "normal_tangential",
    "pooling_experiment",
    "radial_projection",
    "sliding_window_std",
    "sphere_normal",
    "target_statistics",
    "task_uncertainty",
    "thermal_reference_value",
    "window_statistics",
]
