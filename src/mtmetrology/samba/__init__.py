"""SAMBA five-axis calibration (master balls + scale bar): records, simulation, calibration,
uncertainty through the identification (GUF and Monte Carlo), and the length check.

- :mod:`~mtmetrology.samba.artefact` — the artefact file (balls, scale bar, stylus tip);
- :mod:`~mtmetrology.samba.setup` — set-ups and the default probing sequence;
- :mod:`~mtmetrology.samba.records` — the three records forms (centres, raw points, campaigns);
- :mod:`~mtmetrology.samba.simulate` — records of a virtual machine;
- :mod:`~mtmetrology.samba.calibrate` — the identification and its RESULT document;
- :mod:`~mtmetrology.samba.uncertainty` — GUF, Monte Carlo and their JCGM 102 validation;
- :mod:`~mtmetrology.samba.verify` — the gauge-block length check;
- :mod:`~mtmetrology.samba.campaign_unexplained` — cov(e) from repeated campaigns.
"""

from mtmetrology._lazy import lazy_exports

_EXPORTS = {
    "SambaArtefact": "mtmetrology.samba.artefact",
    "load_artefact": "mtmetrology.samba.artefact",
    "SambaCalibration": "mtmetrology.samba.calibrate",
    "CampaignUnexplained": "mtmetrology.samba.campaign_unexplained",
    "unexplained_from_campaigns": "mtmetrology.samba.campaign_unexplained",
    "calibrate": "mtmetrology.samba.calibrate",
    "SetupIdentifiability": "mtmetrology.samba.identifiability",
    "setup_identifiability": "mtmetrology.samba.identifiability",
    "SambaRecords": "mtmetrology.samba.records",
    "read_records": "mtmetrology.samba.records",
    "SambaSetup": "mtmetrology.samba.setup",
    "probing_sequence": "mtmetrology.samba.setup",
    "BallLayout": "mtmetrology.samba.simulate",
    "ProbingProgramme": "mtmetrology.samba.simulate",
    "load_balls": "mtmetrology.samba.simulate",
    "read_poses": "mtmetrology.samba.simulate",
    "simulate_records": "mtmetrology.samba.simulate",
    "SambaUncertainty": "mtmetrology.samba.uncertainty",
    "evaluate_uncertainty": "mtmetrology.samba.uncertainty",
    "indication_inputs": "mtmetrology.samba.uncertainty",
    "uncertainty_model": "mtmetrology.samba.uncertainty",
    "LengthCheck": "mtmetrology.samba.verify",
    "read_length_readings": "mtmetrology.samba.verify",
    "simulate_length_check": "mtmetrology.samba.verify",
    "simulate_length_readings": "mtmetrology.samba.verify",
    "verify_length": "mtmetrology.samba.verify",
}

__all__ = [
    "BallLayout",
    "CampaignUnexplained",
    "LengthCheck",
    "ProbingProgramme",
    "SambaArtefact",
    "SambaCalibration",
    "SambaRecords",
    "SambaSetup",
    "SambaUncertainty",
    "SetupIdentifiability",
    "calibrate",
    "evaluate_uncertainty",
    "indication_inputs",
    "load_artefact",
    "load_balls",
    "probing_sequence",
    "read_length_readings",
    "read_poses",
    "read_records",
    "setup_identifiability",
    "simulate_length_check",
    "simulate_length_readings",
    "simulate_records",
    "uncertainty_model",
    "unexplained_from_campaigns",
    "verify_length",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
