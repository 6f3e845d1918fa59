"""Laser-tracker volumetric verification of a three-axis machine tool (Aguado et al. (2019)).

Workflows (library functions returning one frozen result object each):

- :func:`simulate` — tracker readings of a machine with known errors;
- :func:`calibrate` — the error functions (with covariance) and the tracker pose;
- :func:`verify` — Monte Carlo of the whole verification;
- :func:`plan_placement` — where to put the tracker.

The instrument model lives in the kinematic engine
(:mod:`mtmetrology.kinematics.tracker`), the datum choice in the identification engine
(:mod:`mtmetrology.identification.datum`).
"""

from mtmetrology.tracker.calibrate import TrackerCalibration, calibrate
from mtmetrology.tracker.placement import PAPER_REGION, PlacementStudy, plan_placement
from mtmetrology.tracker.setup import PAPER_POSE, MachineConditions, cte_uncertainty, parse_mesh
from mtmetrology.tracker.simulate import TrackerMeasurements, read_measurements, simulate
from mtmetrology.tracker.verify import TrackerVerification, verify

__all__ = [
    "PAPER_POSE",
    "PAPER_REGION",
    "MachineConditions",
    "PlacementStudy",
    "TrackerCalibration",
    "TrackerMeasurements",
    "TrackerVerification",
    "calibrate",
    "cte_uncertainty",
    "parse_mesh",
    "plan_placement",
    "read_measurements",
    "simulate",
    "verify",
]
