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
- :mod:`~mtmetrology.uncertainty.normal_coverage` — k and p of the region of n normal
  quantities, p = P(χ²_n ≤ k²), for every region stated;
- :mod:`~mtmetrology.uncertainty.validation` — GUF validated by Monte Carlo;
- :mod:`~mtmetrology.uncertainty.executors` — in-process, process pool, Dask;
- :mod:`~mtmetrology.uncertainty.modelfile` — measurement models in YAML;
- :mod:`~mtmetrology.uncertainty.evaluation` — a model file by the GUF, Monte Carlo or
  both, validated (what ``mtm uncertainty run`` computes);
- :mod:`~mtmetrology.uncertainty.conformity` — ISO 14253-1 decision rules (JCGM 106): a
  specification ``Tolerance`` and ``decide``;
- :mod:`~mtmetrology.uncertainty.unexplained_estimate` — a 3×3 error covariance (cov(e))
  estimated from residual vectors, PSD by eigenvalue clipping (import it by its path).

The names load on first use (PEP 562): importing one module (``conformity`` for a
command's options) does not import the others (scipy, the model-file parser).
"""

from typing import TYPE_CHECKING

from mtmetrology._lazy import lazy_exports

# Imported now, not on first use: the function ``guf`` shares its name with its module,
# which would otherwise take the package attribute once imported.
from mtmetrology.uncertainty.guf import GUFResult, guf

#: Public name -> module that defines it (loaded on first use, PEP 562).
_EXPORTS = {
    "ConformityDecision": "mtmetrology.uncertainty.conformity",
    "Decision": "mtmetrology.uncertainty.conformity",
    "Tolerance": "mtmetrology.uncertainty.conformity",
    "decide": "mtmetrology.uncertainty.conformity",
    "Arcsine": "mtmetrology.uncertainty.distributions",
    "Beta": "mtmetrology.uncertainty.distributions",
    "CurvilinearTrapezoid": "mtmetrology.uncertainty.distributions",
    "MultivariateNormal": "mtmetrology.uncertainty.distributions",
    "MultivariateT": "mtmetrology.uncertainty.distributions",
    "Normal": "mtmetrology.uncertainty.distributions",
    "Rectangular": "mtmetrology.uncertainty.distributions",
    "Samples": "mtmetrology.uncertainty.distributions",
    "StudentT": "mtmetrology.uncertainty.distributions",
    "Trapezoidal": "mtmetrology.uncertainty.distributions",
    "Triangular": "mtmetrology.uncertainty.distributions",
    "make_distribution": "mtmetrology.uncertainty.distributions",
    "DaskExecutor": "mtmetrology.uncertainty.executors",
    "InProcessExecutor": "mtmetrology.uncertainty.executors",
    "ProcessPoolExecutor": "mtmetrology.uncertainty.executors",
    "resolve_executor": "mtmetrology.uncertainty.executors",
    "InputQuantity": "mtmetrology.uncertainty.inputs",
    "InputSet": "mtmetrology.uncertainty.inputs",
    "MCMResult": "mtmetrology.uncertainty.mcm",
    "monte_carlo": "mtmetrology.uncertainty.mcm",
    "MeasurementModel": "mtmetrology.uncertainty.modelfile",
    "load_model": "mtmetrology.uncertainty.modelfile",
    "ModelEvaluation": "mtmetrology.uncertainty.evaluation",
    "evaluate_model": "mtmetrology.uncertainty.evaluation",
    "Output": "mtmetrology.uncertainty.outputs",
    "result_document": "mtmetrology.uncertainty.outputs",
    "UncertaintyResult": "mtmetrology.uncertainty.result",
    "ValidationReport": "mtmetrology.uncertainty.validation",
    "validate_guf": "mtmetrology.uncertainty.validation",
    "validate_results": "mtmetrology.uncertainty.validation",
}

if TYPE_CHECKING:
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
    from mtmetrology.uncertainty.evaluation import ModelEvaluation, evaluate_model
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
    "ModelEvaluation",
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
    "evaluate_model",
    "guf",
    "load_model",
    "make_distribution",
    "monte_carlo",
    "resolve_executor",
    "result_document",
    "validate_guf",
    "validate_results",
]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
