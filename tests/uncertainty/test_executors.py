"""Executors: the same seed gives the same Monte Carlo result on any executor and worker count."""

import numpy as np
import pytest
from threadpoolctl import threadpool_info, threadpool_limits

from mtmetrology.uncertainty.executors import (
    DaskExecutor,
    InProcessExecutor,
    ProcessPoolExecutor,
    resolve_executor,
)
from mtmetrology.uncertainty.inputs import InputSet
from mtmetrology.uncertainty.mcm import ModelEvaluationError, monte_carlo


def normal_inputs(mean, std):
    """Independent normal inputs x0, x1, ... as an InputSet (picklable for workers)."""
    std = np.asarray(std, dtype=float)
    return InputSet.from_covariance([f"x{i}" for i in range(std.size)], mean, np.diag(std**2))


def product_and_ratio(x):
    """A non-linear 2-output model (m = 2) so that λ_max and k_p enter the adaptive rule."""
    return np.column_stack([x[:, 0] * x[:, 1], x[:, 0] / x[:, 1]])


def logarithm(x):
    return np.log(x[:, 0])


INPUTS = normal_inputs([2.0, 3.0], [0.2, 0.1])


def assert_identical(first, second):
    """Bit-identical statistics, not merely close."""
    assert first.trials == second.trials and first.sequences == second.sequences
    for name in ("estimate", "covariance", "interval", "interval_shortest"):
        np.testing.assert_array_equal(getattr(first, name), getattr(second, name))
    assert first.region_coverage_factor == second.region_coverage_factor
    assert first.largest_eigenvalue == second.largest_eigenvalue


def test_in_process_executor_maps_in_order():
    executor, owned = resolve_executor(None)
    assert isinstance(executor, InProcessExecutor) and owned
    assert executor.map(abs, [-3, 1, -2]) == [3, 1, 2]


def test_resolve_executor_specifications():
    pool, owned = resolve_executor(2)
    assert isinstance(pool, ProcessPoolExecutor) and pool.workers == 2 and owned
    named, _ = resolve_executor("processes:3")
    assert named.workers == 3
    mine = InProcessExecutor()
    assert resolve_executor(mine) == (mine, False)
    with pytest.raises(ValueError, match="integer"):
        resolve_executor("processes:two")
    with pytest.raises(TypeError, match="executor must be"):
        resolve_executor(3.5)
    with pytest.raises(TypeError, match="executor must be"):
        resolve_executor(True)
    with pytest.raises(ValueError, match="workers"):
        ProcessPoolExecutor(0)


def test_fixed_run_is_bit_identical_in_process_and_on_1_or_2_processes():
    """Chunk streams depend on (seed, chunk index) only, and chunks are reduced in order."""
    options = {"trials": 40_000, "chunk_size": 7_000, "seed": 2024}
    reference = monte_carlo(product_and_ratio, INPUTS, **options)
    with ProcessPoolExecutor(1) as one, ProcessPoolExecutor(2) as two:
        assert_identical(reference, monte_carlo(product_and_ratio, INPUTS, executor=one, **options))
        assert_identical(reference, monte_carlo(product_and_ratio, INPUTS, executor=two, **options))


def blas_threads(_=None) -> list[int]:
    """Threads of every BLAS pool loaded in this process."""
    return [pool["num_threads"] for pool in threadpool_info() if pool["user_api"] == "blas"]


def test_pool_workers_run_one_blas_thread_and_leave_the_caller_alone():
    """Forked workers inherit the parent's BLAS threads (2 here): the pool's initializer
    pins each to 1, so 2 workers put 2 threads, not 4, on the cores."""
    with threadpool_limits(2):
        caller = blas_threads()
        with ProcessPoolExecutor(2) as pool:
            per_task = pool.map(blas_threads, range(4))
        assert blas_threads() == caller == [2] * len(caller)
    assert per_task == [[1] * len(caller)] * 4


def test_adaptive_run_stops_at_the_same_sequence_for_any_worker_count():
    """With 2 workers sequences are computed two at a time but tested in order, so the
    stopping point and every statistic equal the one-at-a-time in-process run."""
    options = {"adaptive": True, "digits": 2, "seed": 7, "sequence_size": 5_000}
    reference = monte_carlo(product_and_ratio, INPUTS, **options)
    assert reference.converged and reference.sequences > 2
    with ProcessPoolExecutor(2) as two:
        assert_identical(reference, monte_carlo(product_and_ratio, INPUTS, executor=two, **options))


def test_model_errors_cross_the_process_boundary():
    with ProcessPoolExecutor(2) as pool, np.errstate(invalid="ignore"):
        with pytest.raises(ModelEvaluationError, match=r"output 0: \d+ trials"):
            monte_carlo(logarithm, normal_inputs([0.5], [1.0]), trials=4_000, executor=pool)


@pytest.mark.slow
def test_dask_local_cluster_gives_the_same_result():
    """A 2-worker in-process Dask cluster (threads: starts in about a second)."""
    options = {"trials": 30_000, "chunk_size": 6_000, "seed": 99}
    reference = monte_carlo(product_and_ratio, INPUTS, **options)
    executor = DaskExecutor("dask-local", workers=2)
    try:
        assert executor.workers == 2
        assert_identical(
            reference, monte_carlo(product_and_ratio, INPUTS, executor=executor, **options)
        )
        adaptive = {"adaptive": True, "seed": 5, "sequence_size": 5_000}
        assert_identical(
            monte_carlo(product_and_ratio, INPUTS, **adaptive),
            monte_carlo(product_and_ratio, INPUTS, executor=executor, **adaptive),
        )
    finally:
        executor.close()


@pytest.mark.slow
def test_dask_local_by_name_is_closed_after_the_run():
    result = monte_carlo(
        product_and_ratio, INPUTS, trials=5_000, chunk_size=2_500, seed=1, executor="dask-local"
    )
    reference = monte_carlo(product_and_ratio, INPUTS, trials=5_000, chunk_size=2_500, seed=1)
    assert_identical(reference, result)


@pytest.mark.slow
def test_dask_scheduler_address_and_client_are_accepted_and_left_open():
    """A scheduler address string and a user's Client give the same result; the user's
    cluster and client stay open afterwards (the executor closes only what it started)."""
    import distributed

    options = {"trials": 8_000, "chunk_size": 2_000, "seed": 3}
    reference = monte_carlo(product_and_ratio, INPUTS, **options)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
    ) as cluster:
        by_address = monte_carlo(
            product_and_ratio, INPUTS, executor=cluster.scheduler_address, **options
        )
        assert_identical(reference, by_address)
        with distributed.Client(cluster) as client:
            assert_identical(
                reference, monte_carlo(product_and_ratio, INPUTS, executor=client, **options)
            )
            assert client.status == "running"
