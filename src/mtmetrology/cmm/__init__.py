"""CMM calibration from ball-plate measurements: kinematic and Gaussian-process error models.

- :mod:`~mtmetrology.cmm.files` — plate, probe-set, plate-position files; records CSV;
- :mod:`~mtmetrology.cmm.problem` — the ball-plate observation model (errors, poses, balls);
- :mod:`~mtmetrology.cmm.models` — seed and full 21-function models, datum chosen by rank;
- :mod:`~mtmetrology.cmm.calibrate` — identification, U1/U2/U3, leave-one-position-out;
- :mod:`~mtmetrology.cmm.simulate` — virtual CMM records;
- :mod:`~mtmetrology.cmm.gp` — Gaussian-process error model (scikit-learn);
- :mod:`~mtmetrology.cmm.compare` — kinematic versus GP on held-out positions;
- :mod:`~mtmetrology.cmm.budget` — the 15-item ball-plate budget with Edlén;
- :mod:`~mtmetrology.cmm.experiment` — set-ups against the certificate (Table 6.8).

Reference: Salacheep, P. (2016). *Error Compensation and Uncertainty Evaluation of CMMs
Based on Kinematic Error Models and Gaussian Processes*. MPhil thesis, Brunel University
London.
"""

from mtmetrology.cmm.budget import ballplate_budget, edlen_refractivity
from mtmetrology.cmm.calibrate import BallPlateCalibration, calibrate_ballplate, cross_validate
from mtmetrology.cmm.compare import ModelComparison, compare_models
from mtmetrology.cmm.files import (
    BallPlate,
    BallPlateRecords,
    PositionSet,
    ProbeSet,
    load_plate,
    load_positions,
    load_probes,
    read_records,
)
from mtmetrology.cmm.gp import GPErrorModel, fit_gp
from mtmetrology.cmm.models import choose_datum, parse_model
from mtmetrology.cmm.problem import BallPlateProblem
from mtmetrology.cmm.simulate import SimulatedCampaign, simulate_ballplate

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
