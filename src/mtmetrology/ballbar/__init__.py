"""ISO 230-4 circular tests with a ballbar: records, the standard's results, and the
diagnosis as an identification of the ISO 230-1 model of the plane's axes.

- :mod:`~mtmetrology.ballbar.records` — the neutral CSV and the test conditions;
- :mod:`~mtmetrology.ballbar.iso230_4` — G, H, F per direction;
- :mod:`~mtmetrology.ballbar.model` — the reading as an observation of the kinematic chain;
- :mod:`~mtmetrology.ballbar.diagnose` — simulation, identification, second-test advice.
"""

from mtmetrology._lazy import lazy_exports

_EXPORTS = {
    "PLANES": "mtmetrology.ballbar.records",
    "BallbarConditions": "mtmetrology.ballbar.records",
    "BallbarTest": "mtmetrology.ballbar.records",
    "nominal_test": "mtmetrology.ballbar.records",
    "read_ballbar": "mtmetrology.ballbar.records",
    "write_ballbar": "mtmetrology.ballbar.records",
    "CircularResults": "mtmetrology.ballbar.iso230_4",
    "circular_deviation": "mtmetrology.ballbar.iso230_4",
    "circular_results": "mtmetrology.ballbar.iso230_4",
    "BallbarProblem": "mtmetrology.ballbar.model",
    "plane_model": "mtmetrology.ballbar.model",
    "BallbarDiagnosis": "mtmetrology.ballbar.diagnose",
    "diagnose": "mtmetrology.ballbar.diagnose",
    "diagnose_many": "mtmetrology.ballbar.diagnose",
    "second_test_advice": "mtmetrology.ballbar.diagnose",
    "simulate": "mtmetrology.ballbar.diagnose",
}

__all__ = sorted(_EXPORTS)

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
