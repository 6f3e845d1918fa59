"""Calibration planning: design criteria, DETMAX exchange, SAMBA artefact and programme."""

from mtmetrology.design.criteria import (
    CRITERIA,
    criterion_from_spectrum,
    scaled_spectrum,
    uncertainty_propagation_factors,
)
from mtmetrology.design.detmax import BlockInformation, DetmaxResult, DetmaxRun, detmax, detmax_run

__all__ = [
    "CRITERIA",
    "BlockInformation",
    "DetmaxResult",
    "DetmaxRun",
    "criterion_from_spectrum",
    "detmax",
    "detmax_run",
    "scaled_spectrum",
    "uncertainty_propagation_factors",
]
