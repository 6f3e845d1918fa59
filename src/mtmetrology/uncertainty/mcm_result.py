"""The result of a Monte Carlo propagation of distributions (JCGM 101:2008, JCGM 102:2011).

:class:`MCMResult` adds to the fields every method shares
(:class:`~mtmetrology.uncertainty.result.UncertaintyResult`) what only a sample gives:
the shortest coverage intervals, the histograms, the run (trials, sequences) and the
stability tests of an adaptive run; :func:`summarise` builds it from the model values.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from mtmetrology.uncertainty.outputs import output_labels
from mtmetrology.uncertainty.regions import (
    Histogram,
    PairwiseAreas,
    histogram,
    intervals_and_histograms,
    pairwise_areas,
)
from mtmetrology.uncertainty.result import UncertaintyResult
from mtmetrology.uncertainty.sample_statistics import correlation_matrix, joint_coverage_factors
from mtmetrology.uncertainty.stability import ConvergenceCheck, NumericalTolerance

__all__ = ["HISTOGRAM_BINS", "MCMResult", "summarise"]

#: Bins of the density histogram stored for each output.
HISTOGRAM_BINS = 100


@dataclass(frozen=True, eq=False)
class MCMResult(UncertaintyResult):
    """Result of :func:`~mtmetrology.uncertainty.mcm.monte_carlo`: the fields of
    :class:`.UncertaintyResult` from the sample (estimate: the mean of the model values,
    JCGM 101, 7.6; covariance: the sample covariance; interval: probabilistically
    symmetric, JCGM 101, 7.7, the one JCGM 101, 8.2 compares with the GUF; U its
    half-width and k = U/u(y); k_p and k_q from the sample, JCGM 102, 7.7.2 and 7.7.3,
    None for one output) and Monte Carlo's own.

    Attributes
    ----------
    interval_shortest : (m, 2) ndarray
        Shortest coverage intervals (JCGM 101, 7.7).
    trials : int
        Number of model evaluations used.
    sequences : int
        Number of sequences h (1 for a fixed number of trials).
    converged : bool or None
        Whether the adaptive procedure met its tolerances; None for a fixed run.
    tolerance : NumericalTolerance or None
        Tolerances of the adaptive procedure as applied (None for a fixed run).
    criterion : str or None
        "jcgm" or "strict" for an adaptive run.
    checks : tuple of ConvergenceCheck
        The final stability tests of an adaptive run.
    scalar_model : bool
        The model returned one value per trial.
    histograms : tuple of Histogram
        A 100-bin density histogram of each output.
    message : str
        What happened, in words (for people; programs read the fields above).
    samples : (trials, m) ndarray or None
        The model values, when ``keep_samples`` was asked for.
    """

    method: ClassVar[str] = "mcm"

    interval_shortest: np.ndarray
    trials: int
    sequences: int
    converged: bool | None
    tolerance: NumericalTolerance | None
    criterion: str | None
    checks: tuple[ConvergenceCheck, ...]
    scalar_model: bool
    histograms: tuple[Histogram, ...] = field(repr=False)
    message: str
    samples: np.ndarray | None = field(default=None, repr=False)

    def histogram(self, output: int = 0, bins: int | str | None = None, density: bool = True):
        """Histogram of one output: the stored 100-bin one, or recomputed from the samples.

        Raises
        ------
        ValueError
            If ``bins`` or ``density`` differ from the stored histogram and the samples
            were not kept, or ``output`` is out of range.
        """
        if not 0 <= output < self.m:
            raise ValueError(f"output must be in 0..{self.m - 1}, got {output}")
        if (bins is None or bins == HISTOGRAM_BINS) and density:
            return self.histograms[output]
        if self.samples is None:
            raise ValueError("other bins need the samples: run monte_carlo(keep_samples=True)")
        return histogram(
            self.samples[:, output], HISTOGRAM_BINS if bins is None else bins, density=density
        )

    def pairwise_areas(self, i: int, j: int, *, bins: int | None = None) -> PairwiseAreas:
        """Ellipse, rectangle and smallest-region areas of outputs i and j (needs samples)."""
        if self.samples is None:
            raise ValueError("pairwise areas need the samples: run monte_carlo(keep_samples=True)")
        return pairwise_areas(self.samples, i, j, self.p, bins=bins)

    def _per_output_dict(self) -> dict:
        """``interval_shortest``, in the order of ``outputs`` (no samples, no histograms)."""
        return {"interval_shortest": self.interval_shortest.tolist()}

    def _method_dict(self) -> dict:
        """The run: ``trials``, ``sequences``, ``converged``, ``criterion``, ``tolerance``,
        ``checks`` and ``message``."""
        tolerance = None
        if self.tolerance is not None:
            tolerance = {
                "output": np.asarray(self.tolerance.output, dtype=float).tolist(),
                "eigenvalue": self.tolerance.eigenvalue,
                "coverage_factor": self.tolerance.coverage_factor,
            }
        return {
            "trials": self.trials,
            "sequences": self.sequences,
            "converged": self.converged,
            "criterion": self.criterion,
            "tolerance": tolerance,
            "checks": [
                {
                    "quantity": c.quantity,
                    "output": c.output,
                    "spread": c.spread,
                    "tolerance": c.tolerance,
                    "passed": c.passed,
                }
                for c in self.checks
            ],
            "message": self.message,
        }


def _freeze(array: np.ndarray) -> np.ndarray:
    array = np.ascontiguousarray(array)
    array.setflags(write=False)
    return array


def summarise(values, moments, p, labels, *, keep_samples: bool, **run) -> MCMResult:
    """The :class:`MCMResult` of the model values of a run.

    Parameters
    ----------
    values : (M, m) ndarray
        All model values of the run (h·M for an adaptive run).
    moments : Moments
        Their streaming mean and covariance (JCGM 102:2011, 7.6).
    p : float
        Coverage probability.
    labels : tuple
        (names given, units given, ``model.output_names``, ``model.output_units``), see
        :func:`~mtmetrology.uncertainty.outputs.output_labels`.
    keep_samples : bool
        Keep ``values`` (read-only) as the result's ``samples``.
    **run
        The run's own fields of :class:`MCMResult` (``trials``, ``sequences``,
        ``converged``, ``tolerance``, ``criterion``, ``checks``, ``scalar_model``,
        ``message``).

    Returns
    -------
    MCMResult
        Read-only arrays; U_j = half the width of the probabilistically symmetric
        interval and k_j = U_j / u(y_j) (NaN for an output of zero variance).
    """
    estimate = moments.mean
    covariance = moments.covariance
    u = np.sqrt(np.diag(covariance))
    correlation = correlation_matrix(covariance)
    symmetric, shortest, histograms = intervals_and_histograms(values, p, HISTOGRAM_BINS)
    k_p, k_q = joint_coverage_factors(values, estimate, covariance, p)
    expanded = 0.5 * (symmetric[:, 1] - symmetric[:, 0])
    with np.errstate(divide="ignore", invalid="ignore"):
        k = np.where(u > 0, expanded / np.where(u > 0, u, 1.0), np.nan)
    m = u.size
    return MCMResult(
        names=tuple(output_labels(labels[0], labels[2], m, "y")),
        units=tuple(output_labels(labels[1], labels[3], m, "")),
        estimate=_freeze(estimate),
        covariance=_freeze(covariance),
        standard_uncertainty=_freeze(u),
        correlation=_freeze(correlation),
        largest_eigenvalue=1.0 if m == 1 else float(np.linalg.eigvalsh(correlation)[-1]),
        region_coverage_factor=k_p,
        rectangular_coverage_factor=k_q,
        p=p,
        interval=_freeze(symmetric),
        expanded_uncertainty=_freeze(expanded),
        coverage_factor=_freeze(k),
        interval_shortest=_freeze(shortest),
        histograms=histograms,
        samples=_freeze(values) if keep_samples else None,
        **run,
    )
