"""CMM calibration from ball-plate measurements: kinematic and Gaussian-process error models.

- :mod:`~mtmetrology.cmm.files` — plate, probe-set, plate-position files; records CSV;
- :mod:`~mtmetrology.cmm.problem` — the ball-plate observation model (errors, poses, balls);
- :mod:`~mtmetrology.cmm.models` — seed and full 21-function models, datum chosen by rank;
- :mod:`~mtmetrology.cmm.calibrate` — identification, U1/U2/U3, model selection
  (cross-validation on blocks of balls);
- :mod:`~mtmetrology.cmm.simulate` — virtual CMM records;
- :mod:`~mtmetrology.cmm.gp` — Gaussian-process error model (scikit-learn);
- :mod:`~mtmetrology.cmm.compare` — kinematic versus GP on held-out positions;
- :mod:`~mtmetrology.cmm.budget` — the 15-item ball-plate budget with Edlén;
- :mod:`~mtmetrology.cmm.experiment` — set-ups against the certificate (Table 6.8).

Reference: Salacheep, P. (2016). *Error Compensation and Uncertainty Evaluation of CMMs
Based on Kinematic Error Models and Gaussian Processes*. MPhil thesis, Brunel University
London.
"""

from mtmetrology._lazy import lazy_exports

_EXPORTS = {
    "ballplate_budget": "mtmetrology.cmm.budget",
    "edlen_refractivity": "mtmetrology.cmm.budget",
    "BallPlateCalibration": "mtmetrology.cmm.calibrate",
    "calibrate_ballplate": "mtmetrology.cmm.calibrate",
    "cross_validate": "mtmetrology.cmm.calibrate",
    "ModelComparison": "mtmetrology.cmm.compare",
    "compare_models": "mtmetrology.cmm.compare",
    "BallPlate": "mtmetrology.cmm.files",
    "BallPlateRecords": "mtmetrology.cmm.files",
    "PositionSet": "mtmetrology.cmm.files",
    "ProbeSet": "mtmetrology.cmm.files",
    "load_plate": "mtmetrology.cmm.files",
    "load_positions": "mtmetrology.cmm.files",
    "load_probes": "mtmetrology.cmm.files",
    "read_records": "mtmetrology.cmm.files",
    "GPErrorModel": "mtmetrology.cmm.gp",
    "fit_gp": "mtmetrology.cmm.gp",
    "choose_datum": "mtmetrology.cmm.models",
    "parse_model": "mtmetrology.cmm.models",
    "BallPlateProblem": "mtmetrology.cmm.problem",
    "SimulatedCampaign": "mtmetrology.cmm.simulate",
    "simulate_ballplate": "mtmetrology.cmm.simulate",
}

__all__ = [
    "BallPlate",
    "BallPlateCalibration",
    "BallPlateProblem",
    "BallPlateRecords",
    "GPErrorModel",
    "ModelComparison",
    "PositionSet",
    "ProbeSet",
    "SimulatedCampaign",
    "ballplate_budget",
    "calibrate_ballplate",
    "choose_datum",
    "compare_models",
    "cross_validate",
    "edlen_refractivity",
    "fit_gp",
    "load_plate",
    "load_positions",
    "load_probes",
    "parse_model",
    "read_records",
    "simulate_ballplate",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
