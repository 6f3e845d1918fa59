"""Monte Carlo propagation of distributions, fixed or adaptive (JCGM 101:2008, JCGM 102:2011).

The model is evaluated on whole arrays of trials: ``model(X)`` with ``X`` of shape
``(M, N)`` returns ``(M, m)`` or ``(M,)`` (a scalar output). The inputs are any object
with ``sample(rng, size) -> (size, N)``. Trials are cut into chunks of ``chunk_size``
that bound the memory of the inputs and of the model's intermediates; each chunk draws
from its own stream, ``mtmetrology.rng.chunk_generators(sequence_seed, n_chunks)[k]``,
so the result depends on (seed, sequence_size, chunk_size) but never on the executor or
the number of workers.

>>> import numpy as np
>>> class Normal:
...     def sample(self, rng, size):
...         return rng.normal([1.0, 2.0], [0.1, 0.2], size=(size, 2))
>>> result = monte_carlo(lambda x: x.sum(axis=1), Normal(), trials=100_000, seed=1)
>>> round(result.output(0).value, 2), round(result.output(0).u, 2)
(3.0, 0.22)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from mtmetrology.display import NotebookRepr
from mtmetrology.errors import InputError
from mtmetrology.rng import SeedLike, chunk_generators
from mtmetrology.uncertainty.executors import resolve_executor
from mtmetrology.uncertainty.outputs import Output, output_labels, output_records
from mtmetrology.uncertainty.regions import (
    Histogram,
    PairwiseAreas,
    coverage_index,
    coverage_intervals,
    ellipsoidal_coverage_factor,
    histogram,
    intervals_and_histograms,
    pairwise_areas,
    rectangular_coverage_factor,
    scatter,
)

__all__ = [
    "ConvergenceCheck",
    "MCMResult",
    "ModelEvaluationError",
    "NumericalTolerance",
    "check_tolerance",
    "monte_carlo",
    "numerical_tolerance",
]

DEFAULT_CHUNK_SIZE = 100_000
HISTOGRAM_BINS = 100


class ModelEvaluationError(InputError):
    """The model returned values of the wrong shape or non-finite values."""


def numerical_tolerance(value, digits: int = 2):
    """Numerical tolerance δ = ½·10^l of a value stated to ``digits`` significant digits.

    Parameters
    ----------
    value : float or array
        The quantity whose digits are to be meaningful, usually u(y); its magnitude is used.
    digits : int
        Number of significant decimal digits n_dig (1 or 2 in practice).

    Returns
    -------
    float or array
        δ, same shape as ``value``; 0 where ``value`` is 0.

    Raises
    ------
    ValueError
        If digits < 1 or value is not finite.

    Notes
    -----
    JCGM 101:2008, 7.9.2: write the value as c × 10^l with c an n_dig-digit integer; then
    δ = ½ × 10^l. For u = 0.0123 and n_dig = 2, c = 12, l = −3 and δ = 0.0005.

    Examples
    --------
    >>> float(numerical_tolerance(0.0123, 2))
    0.0005
    """
    if int(digits) != digits or digits < 1:
        raise ValueError(f"digits must be a positive integer, got {digits}")
    magnitude = np.abs(np.asarray(value, dtype=float))
    if not np.all(np.isfinite(magnitude)):
        raise ValueError(f"cannot derive a tolerance from a non-finite value {value!r}")
    with np.errstate(divide="ignore"):
        exponent = np.floor(np.log10(np.where(magnitude > 0, magnitude, 1.0))) - int(digits) + 1
    tolerance = np.where(magnitude > 0, 0.5 * 10.0**exponent, 0.0)
    return float(tolerance) if tolerance.ndim == 0 else tolerance


@dataclass(frozen=True, eq=False)
class NumericalTolerance:
    """Numerical tolerances (JCGM 101:2008, 7.9.2) of the adaptive procedure and of GUF
    validation (a specification is :class:`~mtmetrology.uncertainty.conformity.Tolerance`).

    Attributes
    ----------
    output : float or (m,) array
        δ for the estimates, standard uncertainties and interval ends (output units).
    eigenvalue : float, optional
        ρ for the largest eigenvalue of the correlation matrix (dimensionless).
    coverage_factor : float, optional
        κ_p for the hyper-ellipsoidal coverage factor k_p (dimensionless).

    Notes
    -----
    Sepahi Boroujeni (2021), Ch. 7 (Tables 7-1, 7-2): δ = 0.05 µm, ρ = κ_p = 0.05. A field
    left as None is derived from the significant digits (JCGM 101:2008, 7.9.2).
    """

    output: Any
    eigenvalue: float | None = None
    coverage_factor: float | None = None

    def for_outputs(self, m: int) -> np.ndarray:
        """δ as an (m,) array; raises if a per-output array has another length."""
        output = np.asarray(self.output, dtype=float)
        if output.ndim == 1 and output.shape != (m,):
            raise ValueError(f"tolerance has {output.size} entries for {m} model outputs")
        return np.broadcast_to(output, (m,)).copy()


def check_tolerance(tolerance) -> NumericalTolerance | None:
    """A user's tolerance (None, a number, a 1-D array or a NumericalTolerance), checked
    and wrapped.

    Raises
    ------
    ValueError
        If a tolerance is not positive and finite, or the array is not one-dimensional.
    """
    if tolerance is None:
        return None
    if not isinstance(tolerance, NumericalTolerance):
        tolerance = NumericalTolerance(tolerance)
    output = np.asarray(tolerance.output, dtype=float)
    if output.ndim > 1 or not np.all(np.isfinite(output)) or np.any(output <= 0):
        raise ValueError(
            f"tolerance must be a positive number or a 1-D array of them, got {tolerance.output!r}"
        )
    for name in ("eigenvalue", "coverage_factor"):
        value = getattr(tolerance, name)
        if value is not None and not (np.isfinite(value) and value > 0):
            raise ValueError(f"tolerance.{name} must be a positive number, got {value!r}")
    return tolerance


@dataclass(frozen=True)
class ConvergenceCheck:
    """One stability test of the adaptive procedure.

    ``spread`` is 2·s/√h (criterion "jcgm") or s (criterion "strict"), where s is the
    standard deviation of the h per-sequence values of ``quantity`` for ``output``
    (None for the joint quantities λ_max and k_p).
    """

    quantity: str
    output: int | None
    spread: float
    tolerance: float

    @property
    def passed(self) -> bool:
        return bool(self.spread <= self.tolerance)


@dataclass(frozen=True, eq=False)
class MCMResult(NotebookRepr):
    """Results of :func:`monte_carlo` for m outputs, in the vocabulary shared with the GUF.

    Attributes
    ----------
    names, units : tuple of str, length m
        Output names and unit labels.
    estimate : (m,) array
        y, the mean of the model values (JCGM 101, 7.6).
    covariance : (m, m) array
        U_y, the sample covariance.
    standard_uncertainty : (m,) array
        u(y_j) = sqrt(U_y[j, j]).
    correlation : (m, m) array
        R_y = D⁻¹ U_y D⁻¹ (rows of zero-variance outputs are 0 with a unit diagonal).
    largest_eigenvalue : float
        λ_max of R_y (1 for m = 1).
    region_coverage_factor : float or None
        k_p of the hyper-ellipsoidal region from the sample (JCGM 102, 7.7.2); None for
        one output, whose region is its coverage interval.
    rectangular_coverage_factor : float or None
        k_q of the hyper-rectangular region from the sample (JCGM 102, 7.7.3); None for
        one output.
    p : float
        Coverage probability.
    interval, interval_shortest : (m, 2) arrays
        Probabilistically symmetric and shortest coverage intervals (JCGM 101, 7.7).
        ``interval`` is the one JCGM 101, 8.2 compares with the GUF.
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
    samples : (trials, m) array or None
        The model values, when ``keep_samples`` was asked for.
    """

    method: ClassVar[str] = "mcm"

    names: tuple[str, ...]
    units: tuple[str, ...]
    estimate: np.ndarray
    covariance: np.ndarray
    standard_uncertainty: np.ndarray
    correlation: np.ndarray
    largest_eigenvalue: float
    region_coverage_factor: float | None
    rectangular_coverage_factor: float | None
    p: float
    interval: np.ndarray
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

    @property
    def m(self) -> int:
        """Number of outputs."""
        return int(self.estimate.shape[0])

    @property
    def expanded_uncertainty(self) -> np.ndarray:
        """(m,) U_j, half the width of the probabilistically symmetric interval."""
        return 0.5 * (self.interval[:, 1] - self.interval[:, 0])

    @property
    def coverage_factor(self) -> np.ndarray:
        """(m,) k_j = U_j / u(y_j) (NaN for an output of zero variance)."""
        u = self.standard_uncertainty
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(u > 0, self.expanded_uncertainty / np.where(u > 0, u, 1.0), np.nan)

    @property
    def outputs(self) -> tuple[Output, ...]:
        """One :class:`.Output` per output quantity (interval: probabilistically symmetric)."""
        return output_records(self, self.expanded_uncertainty, self.coverage_factor)

    def output(self, key: int | str = 0) -> Output:
        """The :class:`.Output` of one output quantity, by index or name."""
        if isinstance(key, str):
            if key not in self.names:
                raise InputError(f"no output named {key!r}; outputs are {list(self.names)}")
            key = self.names.index(key)
        if not -self.m <= int(key) < self.m:
            raise InputError(f"output index {key} out of range for {self.m} outputs")
        return self.outputs[int(key)]

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

    def to_dict(self) -> dict:
        """JSON-ready result: ``method``, ``outputs`` (:class:`.Output` layout), joint data.

        No samples and no histograms; ``interval_shortest`` lists the shortest intervals
        in the order of ``outputs``.
        """
        tolerance = None
        if self.tolerance is not None:
            tolerance = {
                "output": np.asarray(self.tolerance.output, dtype=float).tolist(),
                "eigenvalue": self.tolerance.eigenvalue,
                "coverage_factor": self.tolerance.coverage_factor,
            }
        return {
            "method": self.method,
            "outputs": [o.to_dict() for o in self.outputs],
            "interval_shortest": self.interval_shortest.tolist(),
            "covariance": {
                "names": list(self.names),
                "units": list(self.units),
                "matrix": self.covariance.tolist(),
            },
            "correlation": self.correlation.tolist(),
            "largest_eigenvalue": self.largest_eigenvalue,
            "region_coverage_factor": self.region_coverage_factor,
            "rectangular_coverage_factor": self.rectangular_coverage_factor,
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


# ---------------------------------------------------------------------------------------
# Chunked evaluation (runs in worker processes: module-level and picklable)


@dataclass(frozen=True)
class _ChunkTask:
    model: Callable
    inputs: Any
    generator: np.random.Generator
    size: int


@dataclass(frozen=True)
class _ChunkOutput:
    values: np.ndarray  # (size, m)
    scalar: bool
    bad_trials: np.ndarray  # (m,) number of non-finite values per output
    first_bad_input: np.ndarray | None  # (N,) inputs of the first non-finite trial


def _evaluate_chunk(task: _ChunkTask) -> _ChunkOutput:
    inputs = np.asarray(task.inputs.sample(task.generator, task.size), dtype=float)
    if inputs.ndim == 1:
        inputs = inputs[:, None]
    if inputs.ndim != 2 or inputs.shape[0] != task.size:
        raise ModelEvaluationError(
            f"inputs.sample(rng, {task.size}) returned shape {inputs.shape}, "
            f"expected ({task.size}, N)"
        )
    values = np.asarray(task.model(inputs), dtype=float)
    scalar = values.ndim == 1
    if scalar:
        values = values[:, None]
    if values.ndim != 2 or values.shape[0] != task.size:
        raise ModelEvaluationError(
            f"model returned shape {values.shape} for inputs of shape {inputs.shape}; "
            f"expected ({task.size}, m) or ({task.size},), one row per trial"
        )
    bad_trials = np.zeros(values.shape[1], dtype=int)
    first_bad = None
    # One reduction decides (a sum is finite only if every value is, bar an overflow, which
    # the detailed count below then clears).
    if not np.isfinite(values.sum()):
        finite = np.isfinite(values)  # (size, m)
        bad_trials = (~finite).sum(axis=0)
        if bad_trials.any():
            first_bad = inputs[np.argmin(finite.all(axis=1))]
    return _ChunkOutput(values, scalar, bad_trials, first_bad)


@dataclass(frozen=True)
class _ChunkBatch:
    """Consecutive chunks of one model and input set: shipped to a worker as one task, so
    the model and inputs are pickled once per batch instead of once per chunk."""

    model: Callable
    inputs: Any
    generators: tuple[np.random.Generator, ...]
    sizes: tuple[int, ...]


def _evaluate_batch(batch: _ChunkBatch) -> list[_ChunkOutput]:
    return [
        _evaluate_chunk(_ChunkTask(batch.model, batch.inputs, g, s))
        for g, s in zip(batch.generators, batch.sizes, strict=True)
    ]


def _batches(tasks: list[_ChunkTask], n_batches: int) -> list[_ChunkBatch]:
    """``tasks`` (one model and input set) in at most ``n_batches`` consecutive runs."""
    per = math.ceil(len(tasks) / max(1, min(n_batches, len(tasks))))
    return [
        _ChunkBatch(
            tasks[0].model,
            tasks[0].inputs,
            tuple(t.generator for t in tasks[i : i + per]),
            tuple(t.size for t in tasks[i : i + per]),
        )
        for i in range(0, len(tasks), per)
    ]


def _root_sequence(seed: SeedLike) -> np.random.SeedSequence:
    """The SeedSequence all sequences and chunks derive from (same rules as mtmetrology.rng)."""
    if isinstance(seed, np.random.Generator):
        return np.random.SeedSequence(int(seed.integers(2**63)))
    if isinstance(seed, np.random.SeedSequence):
        return seed
    return np.random.SeedSequence(seed)


def _sequence_tasks(model, inputs, root, index: int, size: int, chunk_size: int):
    """Chunk tasks of sequence ``index``: its stream is child ``index`` of ``root``."""
    # Built from (entropy, spawn_key) rather than root.spawn(): spawn() is stateful and
    # would give different children on a second call with the same SeedSequence object.
    sequence_seed = np.random.SeedSequence(
        root.entropy, spawn_key=(*root.spawn_key, index), pool_size=root.pool_size
    )
    n_chunks = math.ceil(size / chunk_size)
    sizes = [chunk_size] * (n_chunks - 1) + [size - chunk_size * (n_chunks - 1)]
    generators = chunk_generators(sequence_seed, n_chunks)
    return [_ChunkTask(model, inputs, g, s) for g, s in zip(generators, sizes, strict=True)]


def _run_sequences(executor, model, inputs, root, first: int, count: int, size, chunk_size):
    """Evaluate sequences first..first+count-1; a (size, m) array and scalar flag for each."""
    tasks, owner = [], []
    for index in range(first, first + count):
        sequence = _sequence_tasks(model, inputs, root, index, size, chunk_size)
        tasks += sequence
        owner += [index - first] * len(sequence)
    # two batches per worker: few pickles of the model and inputs, and some load balance
    batches = executor.map(_evaluate_batch, _batches(tasks, 2 * executor.workers))
    outputs = [out for batch in batches for out in batch]
    widths = {out.values.shape[1] for out in outputs}
    if len(widths) != 1 or len({out.scalar for out in outputs}) != 1:
        raise ModelEvaluationError(f"model returned different numbers of outputs: {widths}")
    bad = np.sum([out.bad_trials for out in outputs], axis=0)  # (m,)
    if bad.any():
        first_bad = next(out.first_bad_input for out in outputs if out.bad_trials.any())
        per_output = ", ".join(f"output {j}: {n} trials" for j, n in enumerate(bad) if n)
        raise ModelEvaluationError(
            f"model returned NaN or infinite values ({per_output}, of {count * size} trials "
            f"evaluated); first offending inputs: {np.array2string(first_bad)}"
        )
    sequences = [
        np.concatenate([out.values for out, o in zip(outputs, owner, strict=True) if o == k])
        for k in range(count)
    ]
    return sequences, outputs[0].scalar


# ---------------------------------------------------------------------------------------
# Statistics


class _Moments:
    """Streaming mean and scatter matrix (Chan, Golub and LeVeque pairwise update)."""

    def __init__(self):
        self.count = 0
        self.mean: np.ndarray | None = None
        self.scatter: np.ndarray | None = None

    def add(self, values: np.ndarray) -> None:
        count = values.shape[0]
        mean = values.mean(axis=0)  # (m,)
        deviations = values - mean  # (count, m)
        scatter_matrix = scatter(deviations)  # (m, m)
        if self.count == 0:
            self.count, self.mean, self.scatter = count, mean, scatter_matrix
            return
        total = self.count + count
        delta = mean - self.mean
        self.mean = self.mean + delta * (count / total)
        self.scatter = (
            self.scatter + scatter_matrix + np.outer(delta, delta) * (self.count * count / total)
        )
        self.count = total

    @property
    def covariance(self) -> np.ndarray:
        return self.scatter / (self.count - 1)


def _correlation(covariance: np.ndarray) -> np.ndarray:
    u = np.sqrt(np.diag(covariance))
    positive = u > 0
    safe = np.where(positive, u, 1.0)
    correlation = covariance / np.outer(safe, safe)
    correlation[~positive, :] = 0.0
    correlation[:, ~positive] = 0.0
    np.fill_diagonal(correlation, 1.0)
    return correlation


def _joint_factors(values, estimate, covariance, p) -> tuple[float | None, float | None]:
    """k_p and k_q over the outputs that vary (a constant output adds no dimension).

    None for one output: its coverage region is its coverage interval, and skipping the
    sample distances saves a pass over the values.
    """
    if values.shape[1] == 1:
        return None, None
    u = np.sqrt(np.diag(covariance))
    varying = np.flatnonzero(u > 0)
    if varying.size == 0:
        return 0.0, 0.0
    sub = values[:, varying]
    k_p = ellipsoidal_coverage_factor(
        sub, p, estimate=estimate[varying], covariance=covariance[np.ix_(varying, varying)]
    )
    k_q = rectangular_coverage_factor(
        sub, p, estimate=estimate[varying], standard_uncertainty=u[varying]
    )
    return k_p, k_q


def _sequence_statistics(values: np.ndarray, p: float) -> np.ndarray:
    """Per-sequence values [y (m), u (m), low (m), high (m), (λ_max, k_p if m > 1)]."""
    m = values.shape[1]
    estimate = values.mean(axis=0)
    deviations = values - estimate
    covariance = scatter(deviations) / (values.shape[0] - 1)
    symmetric, _ = coverage_intervals(values, p)  # (m, 2)
    parts = [estimate, np.sqrt(np.diag(covariance)), symmetric[:, 0], symmetric[:, 1]]
    if m > 1:
        largest = np.linalg.eigvalsh(_correlation(covariance))[-1]
        k_p, _ = _joint_factors(values, estimate, covariance, p)
        parts.append(np.array([largest, k_p]))
    return np.concatenate(parts)


_QUANTITIES = ("estimate", "standard uncertainty", "interval low", "interval high")


def _stability_checks(per_sequence, moments, m, tolerance, digits, criterion):
    """The stopping tests of JCGM 101, 7.9.4 / JCGM 102, 7.8 (or the strict s ≤ δ of
    Sepahi Boroujeni 2021, Ch. 5)."""
    table = np.asarray(per_sequence)  # (h, 4m [+ 2])
    h = table.shape[0]
    spread = table.std(axis=0, ddof=1)
    if criterion == "jcgm":
        spread = 2.0 * spread / np.sqrt(h)  # twice the standard deviation of the average
    u = np.sqrt(np.diag(moments.covariance))  # u(y) from all h·M values (7.9.4 h)
    if tolerance is None:
        delta, rho, kappa = numerical_tolerance(u, digits), None, None
    else:
        delta, rho, kappa = (
            tolerance.for_outputs(m),
            tolerance.eigenvalue,
            tolerance.coverage_factor,
        )
    averages = table.mean(axis=0)
    if m > 1:
        rho = numerical_tolerance(averages[4 * m], digits) if rho is None else rho
        kappa = numerical_tolerance(averages[4 * m + 1], digits) if kappa is None else kappa
    checks = [
        ConvergenceCheck(name, j, float(spread[block * m + j]), float(delta[j]))
        for block, name in enumerate(_QUANTITIES)
        for j in range(m)
    ]
    if m > 1:
        checks.append(ConvergenceCheck("largest eigenvalue", None, float(spread[4 * m]), rho))
        checks.append(ConvergenceCheck("coverage factor", None, float(spread[4 * m + 1]), kappa))
    return checks, NumericalTolerance(delta, rho, kappa)


def _freeze(array: np.ndarray) -> np.ndarray:
    array = np.ascontiguousarray(array)
    array.setflags(write=False)
    return array


def _summarise(values, moments, p, labels, **run) -> MCMResult:
    estimate = moments.mean
    covariance = moments.covariance
    u = np.sqrt(np.diag(covariance))
    correlation = _correlation(covariance)
    symmetric, shortest, histograms = intervals_and_histograms(values, p, HISTOGRAM_BINS)
    k_p, k_q = _joint_factors(values, estimate, covariance, p)
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
        interval_shortest=_freeze(shortest),
        histograms=histograms,
        **run,
    )


# ---------------------------------------------------------------------------------------
# Public entry point


def _check_int(name: str, value, minimum: int) -> int:
    if isinstance(value, bool) or int(value) != value or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def monte_carlo(
    model: Callable[[np.ndarray], np.ndarray],
    inputs,
    *,
    trials: int | None = None,
    adaptive: bool = False,
    digits: int = 2,
    tolerance=None,
    criterion: str = "jcgm",
    p: float = 0.95,
    seed: SeedLike = None,
    executor=None,
    sequence_size: int = 10_000,
    chunk_size: int | None = None,
    max_trials: int = 10_000_000,
    keep_samples: bool = False,
    min_sequences: int | None = None,
    output_names=None,
    output_units=None,
) -> MCMResult:
    """Propagate distributions through a model by Monte Carlo (JCGM 101, JCGM 102).

    Parameters
    ----------
    model : callable
        ``model(X)`` with X of shape (M, N) returns (M, m) or (M,), vectorised over trials.
    inputs : object
        Has ``sample(rng, size) -> (size, N)`` (e.g. an ``InputSet``).
    trials : int, optional
        Fixed number of trials M; 10⁶ if neither ``trials`` nor ``adaptive`` is given
        (JCGM 101, 7.2.2).
    adaptive : bool
        Run the adaptive procedure: sequences of ``sequence_size`` trials until the
        stopping rule holds.
    digits : int
        Significant digits n_dig from which the tolerances are derived when ``tolerance``
        does not give them (JCGM 101, 7.9.2).
    tolerance : float, (m,) array or NumericalTolerance, optional
        Explicit δ (output units) per output, or a :class:`Tolerance` with ρ and κ_p too.
    criterion : {"jcgm", "strict"}
        "jcgm": 2·s/√h ≤ δ, s the standard deviation of the h sequence values (JCGM 101,
        7.9.4; JCGM 102, 7.8). "strict": s ≤ δ (Sepahi Boroujeni 2021, Ch. 5, eq. 5-12), which needs
        about h/4 times more sequences.
    p : float
        Coverage probability, 0 < p < 1.
    seed : int, SeedSequence or Generator, optional
        Root of all random streams.
    executor : None, str, int, distributed.Client or Executor
        Where chunks run; see :func:`mtmetrology.uncertainty.executors.resolve_executor`.
    sequence_size : int
        Trials per sequence of the adaptive procedure, at least 100/(1 − p) (JCGM 101,
        7.9.4 b: max(100/(1 − p), 10⁴) is recommended).
    chunk_size : int, optional
        Trials per model call (bounds memory); 10⁵ by default, at most ``sequence_size``
        in adaptive runs. Results depend on it (it cuts the random streams).
    max_trials : int
        Upper bound on the trials of an adaptive run; the result is then returned with
        ``converged=False``.
    keep_samples : bool
        Keep the (trials, m) model values in the result.
    min_sequences : int, optional
        Sequences run before the stopping rule is first tested: 2 for "jcgm" (the least
        that gives a standard deviation), 10 for "strict" (Sepahi Boroujeni 2021, h₀ = 10).
    output_names, output_units : sequence of str, optional
        Default to ``model.output_names`` / ``model.output_units`` or y1..ym (as
        :func:`~mtmetrology.uncertainty.guf.guf`).

    Returns
    -------
    MCMResult

    Raises
    ------
    ValueError
        For an invalid argument (naming it).
    ModelEvaluationError
        If the model returns the wrong shape or non-finite values (how many trials, which
        outputs, and the inputs of the first such trial).

    Notes
    -----
    Output statistics (JCGM 102, 7.6; Sepahi Boroujeni 2021, eqs. 5-9, 5-10): y = mean of the model
    values, U_y = 1/(M − 1) Σ (y_r − y)(y_r − y)ᵀ accumulated chunk by chunk; intervals by
    JCGM 101, 7.7; k_p by JCGM 102, 7.7.2.

    Adaptive procedure (JCGM 101, 7.9.4; JCGM 102, 7.8): after each sequence h ≥
    ``min_sequences``, compute for each of the h sequences y_j, u(y_j), the ends of the
    probabilistically symmetric interval and, for m > 1, λ_max and k_p; stop when each
    spread is within its tolerance: δ_j = ½·10^l from u(y_j) of all h·M values, ρ and
    κ_p from the digits of λ_max and k_p unless given. Final results use all h·M values.
    Sequences are dispatched in batches of ``executor.workers`` but tested in order, so
    the stopping point and the result do not depend on the executor.

    The strict rule tests the spread of single sequences, which does not shrink as h
    grows: it passes once one sequence of ``sequence_size`` trials is stable to δ, so raise
    ``sequence_size`` if it keeps failing.

    All h·M model values are kept in memory for the coverage intervals (m floats per
    trial); ``chunk_size`` bounds the memory of the inputs and of the model's work arrays.
    The intervals come from the two tails only (located by one binning pass, then sorted),
    which gives the order statistics of a full sort at a fraction of its cost; for one
    output the multivariate coverage factors are not computed (None).

    References
    ----------
    JCGM 101:2008, *Evaluation of measurement data — Supplement 1 to the "Guide to the
    expression of uncertainty in measurement" — Propagation of distributions using a Monte
    Carlo method*, clauses 6, 7 and 9.

    JCGM 102:2011, *Evaluation of measurement data — Supplement 2 to the "Guide to the
    expression of uncertainty in measurement" — Extension to any number of output
    quantities*, clauses 7 and 8.

    Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
    Tool Metrology*. PhD thesis, Polytechnique Montréal (the strict stopping rule, Ch. 5).

    Examples
    --------
    JCGM 101:2008, 9.2.3 (Table 3): Y = X₁ + X₂ + X₃ + X₄ with rectangular inputs of
    u = 1; Monte Carlo with M = 10⁶ gives u(y) = 2.00 and the 95 % interval [−3.88, 3.88].

    >>> import numpy as np
    >>> from mtmetrology.uncertainty import InputQuantity, InputSet, Rectangular
    >>> a = np.sqrt(3.0)
    >>> inputs = InputSet([InputQuantity(f"X{i}", Rectangular(-a, a)) for i in range(1, 5)])
    >>> r = monte_carlo(lambda x: x.sum(axis=1), inputs, trials=10**6, seed=9)
    >>> o = r.output()
    >>> print(f"u = {o.u:.2f}, [{o.interval[0]:.2f}, {o.interval[1]:.2f}]")
    u = 2.00, [-3.88, 3.88]
    """
    p = float(p)
    if not 0.0 < p < 1.0:
        raise ValueError(f"p must lie strictly between 0 and 1, got {p}")
    if criterion not in ("jcgm", "strict"):
        raise ValueError(f"criterion must be 'jcgm' or 'strict', got {criterion!r}")
    digits = _check_int("digits", digits, 1)
    tolerance = check_tolerance(tolerance)
    chunk_size = (
        DEFAULT_CHUNK_SIZE if chunk_size is None else _check_int("chunk_size", chunk_size, 1)
    )
    if not callable(model):
        raise TypeError("model must be callable: model(X) with X of shape (M, N)")
    if not callable(getattr(inputs, "sample", None)):
        raise TypeError("inputs must have a sample(rng, size) -> (size, N) method")
    if adaptive and trials is not None:
        raise ValueError("give either trials (a fixed run) or adaptive=True, not both")
    if adaptive:
        sequence_size = _check_int("sequence_size", sequence_size, 2)
        needed = math.ceil(100.0 / (1.0 - p) - 1e-9)
        if sequence_size < needed:
            raise ValueError(
                f"sequence_size={sequence_size} is too small for p={p}: JCGM 101 7.9.4 needs "
                f"at least 100/(1 - p) = {needed} trials per sequence"
            )
        if min_sequences is None:
            min_sequences = 2 if criterion == "jcgm" else 10
        min_sequences = _check_int("min_sequences", min_sequences, 2)
        max_trials = _check_int("max_trials", max_trials, min_sequences * sequence_size)
    else:
        trials = 1_000_000 if trials is None else _check_int("trials", trials, 2)
        coverage_index(trials, p)  # raises if M is too small for p
    root = _root_sequence(seed)
    labels = (
        output_names,
        output_units,
        getattr(model, "output_names", None),
        getattr(model, "output_units", None),
    )
    executor, owned = resolve_executor(executor)
    try:
        if not adaptive:
            return _fixed(
                model, inputs, trials, p, root, executor, chunk_size, keep_samples, labels
            )
        return _adaptive(
            model,
            inputs,
            p,
            root,
            executor,
            min(chunk_size, sequence_size),
            keep_samples,
            labels,
            sequence_size=sequence_size,
            digits=digits,
            tolerance=tolerance,
            criterion=criterion,
            max_trials=max_trials,
            min_sequences=min_sequences,
        )
    finally:
        if owned:
            executor.close()


def _fixed(model, inputs, trials, p, root, executor, chunk_size, keep_samples, labels) -> MCMResult:
    (values,), scalar = _run_sequences(executor, model, inputs, root, 0, 1, trials, chunk_size)
    moments = _Moments()
    for start in range(0, trials, chunk_size):
        moments.add(values[start : start + chunk_size])
    m = values.shape[1]
    return _summarise(
        values,
        moments,
        p,
        labels,
        scalar_model=scalar,
        trials=trials,
        sequences=1,
        converged=None,
        tolerance=None,
        criterion=None,
        checks=(),
        message=f"{trials} trials, {m} output{'s' if m > 1 else ''}"
        + (" (scalar model)" if scalar else ""),
        samples=_freeze(values) if keep_samples else None,
    )


def _adaptive(
    model,
    inputs,
    p,
    root,
    executor,
    chunk_size,
    keep_samples,
    labels,
    *,
    sequence_size,
    digits,
    tolerance,
    criterion,
    max_trials,
    min_sequences,
) -> MCMResult:
    budget = max_trials // sequence_size  # sequences allowed
    kept: list[np.ndarray] = []
    per_sequence: list[np.ndarray] = []
    moments = _Moments()
    checks: list[ConvergenceCheck] = []
    applied = tolerance
    converged = False
    while not converged and len(kept) < budget:
        h = len(kept)
        batch = min_sequences - h if h < min_sequences else executor.workers
        batch = min(batch, budget - h)
        sequences, scalar = _run_sequences(
            executor, model, inputs, root, h, batch, sequence_size, chunk_size
        )
        for values in sequences:
            kept.append(values)
            moments.add(values)
            per_sequence.append(_sequence_statistics(values, p))
            if len(kept) < min_sequences:
                continue
            checks, applied = _stability_checks(
                per_sequence, moments, values.shape[1], tolerance, digits, criterion
            )
            if all(check.passed for check in checks):
                converged = True
                break
    values = np.concatenate(kept)  # (h·M, m)
    h = len(kept)
    rule = "2·s/√h ≤ δ (JCGM 101 7.9.4)" if criterion == "jcgm" else "s ≤ δ (strict)"
    if converged:
        message = f"converged after {h} sequences of {sequence_size} trials ({rule})"
    else:
        failing = [c for c in checks if not c.passed]
        listed = "; ".join(
            f"{c.quantity}{'' if c.output is None else f' [{c.output}]'}: "
            f"{c.spread:.3g} > {c.tolerance:.3g}"
            for c in failing[:5]
        )
        message = (
            f"not converged: max_trials={max_trials} reached after {h} sequences ({rule}); "
            f"{len(failing)} check(s) fail: {listed}"
        )
    return _summarise(
        values,
        moments,
        p,
        labels,
        scalar_model=scalar,
        trials=values.shape[0],
        sequences=h,
        converged=converged,
        tolerance=applied,
        criterion=criterion,
        checks=tuple(checks),
        message=message,
        samples=_freeze(values) if keep_samples else None,
    )
