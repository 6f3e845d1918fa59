"""Chunked evaluation of a Monte Carlo model: batches, random streams, bad model values."""

import numpy as np
import pytest

from mtmetrology.uncertainty.chunks import (
    ModelEvaluationError,
    _batches,
    _ChunkTask,
    root_sequence,
    run_sequences,
)
from mtmetrology.uncertainty.executors import InProcessExecutor
from mtmetrology.uncertainty.inputs import InputSet
from mtmetrology.uncertainty.mcm import monte_carlo

INPUTS = InputSet.from_covariance(["x0", "x1"], [1.0, 0.0], np.diag([0.1, 1.0]) ** 2)


@pytest.mark.parametrize("n_chunks, n_batches", [(1, 4), (7, 2), (50, 4), (3, 3), (5, 1)])
def test_chunks_ship_in_at_most_n_batches_each_in_order_once(n_chunks, n_batches):
    """Batching (one pickle of the model per batch) keeps every chunk's own stream and
    the chunk order, so the results cannot depend on the batch count."""
    tasks = [_ChunkTask(abs, None, np.random.default_rng(k), 10 + k) for k in range(n_chunks)]
    batches = _batches(tasks, n_batches)
    assert 1 <= len(batches) <= n_batches
    assert [s for b in batches for s in b.sizes] == [t.size for t in tasks]
    shipped = [g for b in batches for g in b.generators]
    assert all(g is t.generator for g, t in zip(shipped, tasks, strict=True))


def test_sequence_k_draws_from_its_own_stream_whoever_asks_for_it():
    """Sequence 2 evaluated alone equals the third of sequences 0..2 evaluated together;
    the same seed given again (or as the same SeedSequence twice) gives the same values."""
    executor = InProcessExecutor()
    together, scalar = run_sequences(executor, lambda x: x, INPUTS, root_sequence(5), 0, 3, 50, 7)
    (alone,), _ = run_sequences(executor, lambda x: x, INPUTS, root_sequence(5), 2, 1, 50, 7)
    np.testing.assert_array_equal(together[2], alone)
    assert not scalar and together[0].shape == (50, 2)
    assert not np.array_equal(together[0], together[1])
    root = root_sequence(5)
    first, _ = run_sequences(executor, lambda x: x, INPUTS, root, 0, 1, 50, 7)
    second, _ = run_sequences(executor, lambda x: x, INPUTS, root, 0, 1, 50, 7)
    np.testing.assert_array_equal(first[0], second[0])


def test_non_finite_model_values_name_trials_and_output():
    def log_model(x):
        return np.column_stack([x[:, 0], np.log(x[:, 1])])  # log of negative -> NaN

    with pytest.raises(ModelEvaluationError, match=r"output 1: \d+ trials") as error:
        with np.errstate(invalid="ignore", divide="ignore"):
            monte_carlo(log_model, INPUTS, trials=1_000, seed=41)
    assert "output 0" not in str(error.value)
    assert "first offending inputs" in str(error.value)


def test_progress_reports_every_round_and_changes_no_value():
    """With a progress callback the chunks are evaluated in rounds, a report after each:
    the trials done rise to the total, and the model values are those of a run without."""
    executor = InProcessExecutor()
    plain, _ = run_sequences(executor, lambda x: x, INPUTS, root_sequence(5), 0, 2, 500, 7)
    seen: list[int] = []
    reported, _ = run_sequences(
        executor, lambda x: x, INPUTS, root_sequence(5), 0, 2, 500, 7, seen.append
    )
    for a, b in zip(plain, reported, strict=True):
        np.testing.assert_array_equal(a, b)
    assert seen == sorted(seen) and len(seen) > 1 and seen[-1] == 1000


def test_monte_carlo_reports_trials_of_a_fixed_and_an_adaptive_run():
    """A fixed run reports (done, M) up to M; an adaptive one (done, None) up to the trials
    it ran (its stopping rule decides the end); both give the values of a silent run."""
    model = lambda x: x[:, 0] + x[:, 1]  # noqa: E731
    fixed: list = []
    silent = monte_carlo(model, INPUTS, trials=20_000, seed=2, chunk_size=1_000)
    loud = monte_carlo(
        model, INPUTS, trials=20_000, seed=2, chunk_size=1_000, progress=lambda *a: fixed.append(a)
    )
    assert loud.outputs[0].u == silent.outputs[0].u
    assert fixed[-1] == (20_000, 20_000) and len(fixed) == 10
    adaptive: list = []
    run = monte_carlo(
        model, INPUTS, adaptive=True, digits=1, seed=2, progress=lambda *a: adaptive.append(a)
    )
    assert {total for _, total in adaptive} == {None}
    assert adaptive[-1][0] == run.trials and run.sequences >= 2
    assert [done for done, _ in adaptive] == sorted(done for done, _ in adaptive)
