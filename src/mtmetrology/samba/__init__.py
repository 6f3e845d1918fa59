"""SAMBA five-axis calibration (master balls + scale bar): records, simulation, calibration,
uncertainty through the identification (GUF and Monte Carlo), and the length check.

- :mod:`~mtmetrology.samba.artefact` — the artefact file (balls, scale bar, stylus tip);
- :mod:`~mtmetrology.samba.setup` — set-ups and the default probing sequence;
- :mod:`~mtmetrology.samba.records` — the three records forms (centres, raw points, campaigns);
- :mod:`~mtmetrology.samba.simulate` — records of a virtual machine;
- :mod:`~mtmetrology.samba.calibrate` — the identification and its RESULT document;
- :mod:`~mtmetrology.samba.uncertainty` — GUF, Monte Carlo and their JCGM 102 validation;
- :mod:`~mtmetrology.samba.verify` — the gauge-block length check.
"""

from mtmetrology.samba.artefact import SambaArtefact, load_artefact
from mtmetrology.samba.calibrate import SambaCalibration, calibrate
from mtmetrology.samba.records import SambaRecords, read_records
from mtmetrology.samba.setup import SambaSetup, probing_sequence
from mtmetrology.samba.simulate import (
    BallLayout,
    ProbingProgramme,
    load_balls,
    read_poses,
    simulate_records,
)
from mtmetrology.samba.uncertainty import (
    SambaUncertainty,
    evaluate_uncertainty,
    indication_inputs,
    uncertainty_model,
)
from mtmetrology.samba.verify import (
    LengthCheck,
    read_length_readings,
    simulate_length_readings,
    verify_length,
)

__all__ = [
    "BallLayout",
    "LengthCheck",
    "ProbingProgramme",
    "SambaArtefact",
    "SambaCalibration",
    "SambaRecords",
    "SambaSetup",
    "SambaUncertainty",
    "calibrate",
    "evaluate_uncertainty",
    "indication_inputs",
    "load_artefact",
    "load_balls",
    "probing_sequence",
    "read_length_readings",
    "read_poses",
    "read_records",
    "simulate_length_readings",
    "simulate_records",
    "uncertainty_model",
    "verify_length",
]
