"""Static R-test of the rotary axes (ISO 10791-6 style): sensor readings on a sphere as
observations of the five-axis chain.

- :mod:`~mtmetrology.rtest.model` — sensors, indexations, the observation model;
- :mod:`~mtmetrology.rtest.calibrate` — simulation and identification (datum by rank).
"""

from mtmetrology._lazy import lazy_exports

_EXPORTS = {
    "RTestProblem": "mtmetrology.rtest.model",
    "Sensors": "mtmetrology.rtest.model",
    "indexations": "mtmetrology.rtest.model",
    "rotary_location_candidates": "mtmetrology.rtest.model",
    "RTestCalibration": "mtmetrology.rtest.calibrate",
    "calibrate": "mtmetrology.rtest.calibrate",
    "simulate": "mtmetrology.rtest.calibrate",
}

__all__ = sorted(_EXPORTS)

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
