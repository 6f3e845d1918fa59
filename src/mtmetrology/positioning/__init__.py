"""ISO 230-2 positioning tests of linear axes with a laser interferometer.

- :mod:`~mtmetrology.positioning.data` — the neutral CSV and the test conditions;
- :mod:`~mtmetrology.positioning.parameters` — the parameters of each edition, vectorised;
- :mod:`~mtmetrology.positioning.environment` — Edlén air index and NDE, reversible;
- :mod:`~mtmetrology.positioning.budget` — ISO/TR 230-9 uncertainty (GUF, Monte Carlo);
- :mod:`~mtmetrology.positioning.identify` — the axis's ISO 230-1 ``E_XX`` with covariance;
- :mod:`~mtmetrology.positioning.simulate` — virtual tests;
- :mod:`~mtmetrology.positioning.workflow` — :func:`analyse`, the result document.
"""

from mtmetrology._lazy import lazy_exports

_EXPORTS = {
    "Conditions": "mtmetrology.positioning.data",
    "PositioningTest": "mtmetrology.positioning.data",
    "read_test": "mtmetrology.positioning.data",
    "evaluate": "mtmetrology.positioning.parameters",
    "EDITIONS": "mtmetrology.positioning.parameters",
    "refractive_index": "mtmetrology.positioning.environment",
    "tr230_9_budget": "mtmetrology.positioning.budget",
    "identify_axis": "mtmetrology.positioning.identify",
    "iso_targets": "mtmetrology.positioning.simulate",
    "simulate_test": "mtmetrology.positioning.simulate",
    "simulate_many": "mtmetrology.positioning.simulate",
    "PositioningResult": "mtmetrology.positioning.workflow",
    "analyse": "mtmetrology.positioning.workflow",
}

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
__all__ = sorted(_EXPORTS)
