"""Identification engine: weighted non-linear least squares with identifiability diagnostics."""

from mtmetrology.identification.datum import Datum, choose_datum
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
    gauss_newton,
)

__all__ = [
    "BallCentreProblem",
    "Datum",
    "IdentifiabilityReport",
    "IdentificationError",
    "IdentificationResult",
    "NullDirection",
    "ScaleBar",
    "analyse_identifiability",
    "choose_datum",
    "gauss_newton",
    "observability_indices",
    "senses_from_sequence",
]
