"""Uncertainty engine: distributions, GUF (JCGM 100/102), adaptive Monte Carlo
(JCGM 101/102), coverage regions, GUF validation, executors and model files.

- :mod:`~mtmetrology.uncertainty.distributions` — input distributions, PSD factors;
- :mod:`~mtmetrology.uncertainty.inputs` — input quantities with units, correlations,
  ensembles and Type A inputs from simultaneous observations;
- :mod:`~mtmetrology.uncertainty.outputs` — the output record shared by every method and
  the result document;
- :mod:`~mtmetrology.uncertainty.result` — ``UncertaintyResult``, the fields every method's
  result shares;
- :mod:`~mtmetrology.uncertainty.guf` — law of propagation, budgets, Welch–Satterthwaite;
- :mod:`~mtmetrology.uncertainty.mcm` — fixed and adaptive Monte Carlo;
- :mod:`~mtmetrology.uncertainty.mcm_result` — its result;
- :mod:`~mtmetrology.uncertainty.chunks` — its chunked evaluation and random streams;
- :mod:`~mtmetrology.uncertainty.sample_statistics` — its streaming moments;
- :mod:`~mtmetrology.uncertainty.stability` — its numerical tolerances and stability
  tests (JCGM 101 7.9);
- :mod:`~mtmetrology.uncertainty.regions` — coverage intervals and regions;
- :mod:`~mtmetrology.uncertainty.validation` — GUF validated by Monte Carlo;
- :mod:`~mtmetrology.uncertainty.executors` — in-process, process pool, Dask;
- :mod:`~mtmetrology.uncertainty.modelfile` — measurement models in YAML;
- :mod:`~mtmetrology.uncertainty.conformity` — ISO 14253-1 decision rules (JCGM 106): a
  specification ``Tolerance`` and ``decide``;
- :mod:`~mtmetrology.uncertainty.unexplained_estimate` — a 3×3 error covariance (cov(e))
  estimated from residual vectors, PSD by eigenvalue clipping (import it by its path).
"""

from mtmetrology.uncertainty.conformity import ConformityDecision, Decision, Tolerance, decide
from mtmetrology.uncertainty.distributions import (
    Arcsine,
    Beta,
    CurvilinearTrapezoid,
    MultivariateNormal,
    MultivariateT,
    Normal,
    Rectangular,
    Samples,
    StudentT,
    Trapezoidal,
    Triangular,
    make_distribution,
)
from mtmetrology.uncertainty.executors import (
    DaskExecutor,
    InProcessExecutor,
    ProcessPoolExecutor,
    resolve_executor,
)
from mtmetrology.uncertainty.guf import GUFResult, guf
from mtmetrology.uncertainty.inputs import InputQuantity, InputSet
from mtmetrology.uncertainty.mcm import MCMResult, monte_carlo
from mtmetrology.uncertainty.modelfile import MeasurementModel, load_model
from mtmetrology.uncertainty.outputs import Output, result_document
from mtmetrology.uncertainty.result import UncertaintyResult
from mtmetrology.uncertainty.validation import ValidationReport, validate_guf, validate_results

__all__ = [
    "Arcsine",
    "Beta",
    "ConformityDecision",
    "CurvilinearTrapezoid",
    "DaskExecutor",
    "Decision",
    "GUFResult",
    "InProcessExecutor",
    "InputQuantity",
    "InputSet",
    "MCMResult",
    "MeasurementModel",
    "MultivariateNormal",
    "MultivariateT",
    "Normal",
    "Output",
    "ProcessPoolExecutor",
    "Rectangular",
    "Samples",
    "StudentT",
    "Tolerance",
    "Trapezoidal",
    "Triangular",
    "UncertaintyResult",
    "ValidationReport",
    "decide",
    "guf",
    "load_model",
    "make_distribution",
    "monte_carlo",
    "resolve_executor",
    "result_document",
    "validate_guf",
    "validate_results",
]
