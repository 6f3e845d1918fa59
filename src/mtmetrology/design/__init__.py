"""Calibration planning: design criteria, DETMAX exchange, SAMBA artefact and programme."""

from mtmetrology._lazy import lazy_exports

_EXPORTS = {
    "AccessibilityRule": "mtmetrology.design.accessibility",
    "accessible": "mtmetrology.design.accessibility",
    "estimate_test_duration_h": "mtmetrology.design.counts",
    "indexation_count": "mtmetrology.design.counts",
    "measurement_count": "mtmetrology.design.counts",
    "CRITERIA": "mtmetrology.design.choices",
    "criterion_from_spectrum": "mtmetrology.design.criteria",
    "scaled_spectrum": "mtmetrology.design.criteria",
    "uncertainty_propagation_factors": "mtmetrology.design.criteria",
    "BlockInformation": "mtmetrology.design.detmax",
    "DetmaxResult": "mtmetrology.design.detmax",
    "DetmaxRun": "mtmetrology.design.detmax",
    "detmax": "mtmetrology.design.detmax",
    "detmax_run": "mtmetrology.design.detmax",
    "SambaProgramme": "mtmetrology.design.programme",
    "evaluate_programme": "mtmetrology.design.programme",
    "SambaDesign": "mtmetrology.design.samba",
    "choose_balls": "mtmetrology.design.samba",
    "choose_indexations": "mtmetrology.design.samba",
    "plan_samba": "mtmetrology.design.samba",
}

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

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
