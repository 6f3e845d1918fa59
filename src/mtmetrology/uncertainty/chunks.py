"""Chunked evaluation of a Monte Carlo model: tasks, batches and their random streams.

The M trials of a sequence (JCGM 101:2008, 7.2) are cut into chunks of at most
``chunk_size`` trials that bound the memory of the inputs and of the model's
intermediates.  Sequence ``k`` draws from child ``k`` of the root
:class:`numpy.random.SeedSequence`, and chunk ``c`` of it from
``mtmetrology.rng.chunk_generators(sequence_seed, n_chunks)[c]``: the values depend on
(seed, sequence size, chunk size) but never on the executor or the number of workers
that run the chunks (the inputs are sampled as in JCGM 101:2008, annex C, from streams
that are independent of each other and reproducible from the seed).
Consecutive chunks travel to a worker as one batch, so the model and the input sampler
are pickled once per batch; the results come back and are checked in chunk order.

>>> import numpy as np
>>> from mtmetrology.uncertainty.executors import InProcessExecutor
>>> class Inputs:
...     def sample(self, rng, size):
...         return rng.normal(size=(size, 2))
>>> root = root_sequence(7)
>>> (values,), scalar = run_sequences(
...     InProcessExecutor(), lambda x: x.sum(axis=1), Inputs(), root, 0, 1, 10, 4)
>>> values.shape, scalar
((10, 1), True)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.rng import SeedLike, chunk_generators

__all__ = ["ModelEvaluationError", "root_sequence", "run_sequences"]


class ModelEvaluationError(InputError):
    """The model returned values of the wrong shape or non-finite values."""


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


def root_sequence(seed: SeedLike) -> np.random.SeedSequence:
    """The SeedSequence all sequences and chunks derive from (same rules as mtmetrology.rng).

    Parameters
    ----------
    seed : int, SeedSequence, Generator or None
        A Generator gives one draw of its stream as the entropy; a SeedSequence is used
        as is.

    Returns
    -------
    numpy.random.SeedSequence
    """
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


#: Rounds of a run that reports progress: its batches are evaluated in this many ``map``
#: calls (each of two batches per worker), a progress report after each.
PROGRESS_ROUNDS = 10


def run_sequences(
    executor, model, inputs, root, first: int, count: int, size, chunk_size, progress=None
):
    """Evaluate the Monte Carlo sequences ``first .. first + count - 1``.

    Parameters
    ----------
    executor : Executor
        Where the chunk batches run (:mod:`mtmetrology.uncertainty.executors`); two
        batches per worker.
    model : callable
        ``model(X (M, N)) -> (M, m)`` or ``(M,)``.
    inputs : object
        Has ``sample(rng, size) -> (size, N)``.
    root : numpy.random.SeedSequence
        From :func:`root_sequence`; sequence k draws from its child k.
    first, count : int
        The sequences to evaluate.
    size, chunk_size : int
        Trials per sequence (M of JCGM 101:2008, 7.9.4) and per model call.
    progress : callable, optional
        ``progress(done)`` with the trials evaluated so far in this call, after each of
        :data:`PROGRESS_ROUNDS` rounds of batches. The results do not depend on it: every
        chunk draws from its own stream, whatever batch it is evaluated in.

    Returns
    -------
    sequences : list of (size, m) ndarray
        The model values of each sequence, in order.
    scalar : bool
        The model returned one value per trial.

    Raises
    ------
    ModelEvaluationError
        If the model returns the wrong shape, different numbers of outputs, or NaN or
        infinite values (how many trials per output, and the inputs of the first such
        trial).
    """
    tasks, owner = [], []
    for index in range(first, first + count):
        sequence = _sequence_tasks(model, inputs, root, index, size, chunk_size)
        tasks += sequence
        owner += [index - first] * len(sequence)
    # two batches per worker: few pickles of the model and inputs, and some load balance
    per_round = 2 * executor.workers
    if progress is None:
        batches = executor.map(_evaluate_batch, _batches(tasks, per_round))
    else:
        batches, done = [], 0
        all_batches = _batches(tasks, per_round * PROGRESS_ROUNDS)
        for start in range(0, len(all_batches), per_round):
            batches += executor.map(_evaluate_batch, all_batches[start : start + per_round])
            done += sum(sum(b.sizes) for b in all_batches[start : start + per_round])
            progress(done)
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
