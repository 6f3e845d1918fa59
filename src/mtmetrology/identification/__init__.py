"""Identification engine: weighted non-linear least squares with identifiability diagnostics,
and the uncertainty of what it identifies (:mod:`mtmetrology.identification.uncertainty`:
GUF through the full Jacobian, Monte Carlo re-solving every trial, JCGM 102 validation).

The uncertainty names load on first use (PEP 562): importing the solver does not load the
uncertainty engine.
"""

from mtmetrology._lazy import lazy_exports
from mtmetrology.identification.adequacy import (
    ModelAdequacy,
    model_adequacy,
    residual_patterns,
)
from mtmetrology.identification.datum import (
    Datum,
    SetupTerms,
    choose_datum,
    constant_rotation_candidates,
    exposed_terms,
)
from mtmetrology.identification.diagnostics import (
    IdentifiabilityReport,
    NullDirection,
    analyse_identifiability,
    observability_indices,
)
from mtmetrology.identification.observations import (
    BallCentreProblem,
    ScaleBar,
    senses_from_sequence,
)
from mtmetrology.identification.solver import (
    IdentificationError,
    IdentificationResult,
    levenberg_marquardt,
)

_UNCERTAINTY = {
    name: "mtmetrology.identification.uncertainty"
    for name in (
        "IdentificationModel",
        "identification_guf",
        "identification_mcm",
        "input_sensitivities",
        "joint_coverage",
        "unknowns_covariance",
        "validate_identification",
    )
}

__all__ = [
    "BallCentreProblem",
    "Datum",
    "IdentifiabilityReport",
    "IdentificationError",
    "IdentificationResult",
    "ModelAdequacy",
    "NullDirection",
    "ScaleBar",
    "SetupTerms",
    "analyse_identifiability",
    "choose_datum",
    "constant_rotation_candidates",
    "exposed_terms",
    "levenberg_marquardt",
    "model_adequacy",
    "observability_indices",
    "residual_patterns",
    "senses_from_sequence",
    *_UNCERTAINTY,
]

__getattr__, __dir__ = lazy_exports(__name__, _UNCERTAINTY)
