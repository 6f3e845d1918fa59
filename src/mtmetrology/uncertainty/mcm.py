"""Monte Carlo propagation of distributions, fixed or adaptive (JCGM 101:2008, JCGM 102:2011).

The model is evaluated on whole arrays of trials: ``model(X)`` with ``X`` of shape
``(M, N)`` returns ``(M, m)`` or ``(M,)`` (a scalar output). The inputs are any object
with ``sample(rng, size) -> (size, N)``. Trials are cut into chunks of ``chunk_size``
that bound the memory of the inputs and of the model's intermediates; each chunk draws
from its own stream, ``mtmetrology.rng.chunk_generators(sequence_seed, n_chunks)[k]``,
so the result depends on (seed, sequence_size, chunk_size) but never on the executor or
the number of workers.

The parts of a run live in their own modules: the chunked evaluation and its random
streams in :mod:`~mtmetrology.uncertainty.chunks`, the streaming moments in
:mod:`~mtmetrology.uncertainty.sample_statistics`, the numerical tolerances and stability
tests of the adaptive procedure (JCGM 101:2008, 7.9) in
:mod:`~mtmetrology.uncertainty.stability`, and the result in
:mod:`~mtmetrology.uncertainty.mcm_result`.

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

import numpy as np

from mtmetrology.rng import SeedLike
from mtmetrology.uncertainty.chunks import ModelEvaluationError, root_sequence, run_sequences
from mtmetrology.uncertainty.executors import resolve_executor
from mtmetrology.uncertainty.mcm_result import MCMResult, summarise
from mtmetrology.uncertainty.regions import coverage_index
from mtmetrology.uncertainty.sample_statistics import Moments
from mtmetrology.uncertainty.stability import (
    ConvergenceCheck,
    NumericalTolerance,
    check_tolerance,
    numerical_tolerance,
    sequence_statistics,
    stability_checks,
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

#: Trials per model call unless ``chunk_size`` is given.
DEFAULT_CHUNK_SIZE = 100_000


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
    progress: Callable[[int, int | None], None] | None = None,
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
        Explicit δ (output units) per output, or a :class:`.NumericalTolerance` with ρ
        and κ_p too.
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

    progress : callable, optional
        ``progress(done, total)`` as the trials are evaluated, for a progress display:
        ``total`` is the trials of a fixed run, None in an adaptive one (its stopping rule
        decides). The result does not depend on it.

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
    root = root_sequence(seed)
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
                model, inputs, trials, p, root, executor, chunk_size, keep_samples, labels,
                progress=_trials_done(progress, 0, trials),
            )  # fmt: skip
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
            progress=progress,
        )
    finally:
        if owned:
            executor.close()


def _trials_done(progress, before: int, total: int | None):
    """``run_sequences``' ``progress(done)`` as the caller's ``progress(before + done, total)``."""
    if progress is None:
        return None
    return lambda done: progress(before + done, total)


def _fixed(
    model, inputs, trials, p, root, executor, chunk_size, keep_samples, labels, progress=None
) -> MCMResult:
    (values,), scalar = run_sequences(
        executor, model, inputs, root, 0, 1, trials, chunk_size, progress
    )
    moments = Moments()
    for start in range(0, trials, chunk_size):
        moments.add(values[start : start + chunk_size])
    m = values.shape[1]
    return summarise(
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
        keep_samples=keep_samples,
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
    progress=None,
) -> MCMResult:
    budget = max_trials // sequence_size  # sequences allowed
    kept: list[np.ndarray] = []
    per_sequence: list[np.ndarray] = []
    moments = Moments()
    checks: list[ConvergenceCheck] = []
    applied = tolerance
    converged = False
    while not converged and len(kept) < budget:
        h = len(kept)
        batch = min_sequences - h if h < min_sequences else executor.workers
        batch = min(batch, budget - h)
        sequences, scalar = run_sequences(
            executor, model, inputs, root, h, batch, sequence_size, chunk_size,
            _trials_done(progress, h * sequence_size, None),
        )  # fmt: skip
        for values in sequences:
            kept.append(values)
            moments.add(values)
            per_sequence.append(sequence_statistics(values, p))
            if len(kept) < min_sequences:
                continue
            checks, applied = stability_checks(
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
    return summarise(
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
        keep_samples=keep_samples,
    )
