"""Calibration planning: design criteria, DETMAX exchange, SAMBA artefact and programme."""

from mtmetrology.design.accessibility import AccessibilityRule, accessible
from mtmetrology.design.counts import (
    estimate_test_duration_h,
    indexation_count,
    measurement_count,
)
from mtmetrology.design.criteria import (
    CRITERIA,
    criterion_from_spectrum,
    scaled_spectrum,
    uncertainty_propagation_factors,
)
from mtmetrology.design.detmax import BlockInformation, DetmaxResult, DetmaxRun, detmax, detmax_run
from mtmetrology.design.programme import SambaProgramme, evaluate_programme
from mtmetrology.design.samba import (
    SambaDesign,
    choose_balls,
    choose_indexations,
    plan_samba,
)

__all__ = [
    "CRITERIA",
    "AccessibilityRule",
    "BlockInformation",
    "DetmaxResult",
    "DetmaxRun",
    "SambaDesign",
    "SambaProgramme",
    "accessible",
    "choose_balls",
    "choose_indexations",
    "criterion_from_spectrum",
    "detmax",
    "detmax_run",
    "estimate_test_duration_h",
    "evaluate_programme",
    "indexation_count",
    "measurement_count",
    "plan_samba",
    "scaled_spectrum",
    "uncertainty_propagation_factors",
]
