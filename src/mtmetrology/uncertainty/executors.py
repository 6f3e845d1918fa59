"""Where Monte Carlo chunks run: in-process, a local process pool, or a Dask cluster.

An executor maps a picklable function over a list of tasks and returns the results in
task order. :func:`mtmetrology.uncertainty.mcm.monte_carlo` cuts its trials into chunks
whose random streams depend only on (seed, sequence, chunk index), never on the worker
that runs them, and reduces the results in chunk order: the same seed gives bit-identical
results for any executor and any number of workers.

>>> from mtmetrology.uncertainty.executors import resolve_executor
>>> executor, owned = resolve_executor(None)
>>> executor.map(abs, [-1, 2, -3])
[1, 2, 3]
"""

from __future__ import annotations

import concurrent.futures
import multiprocessing
import os
from collections.abc import Callable, Sequence
from typing import Any, Protocol, runtime_checkable

from mtmetrology._backend import pin_one_thread

__all__ = [
    "DaskExecutor",
    "Executor",
    "InProcessExecutor",
    "ProcessPoolExecutor",
    "resolve_executor",
]


@runtime_checkable
class Executor(Protocol):
    """What :func:`monte_carlo` needs from an executor.

    ``workers`` is the number of tasks that run at once; ``map`` returns the results of
    ``function(task)`` in the order of ``tasks``; ``close`` releases what the executor
    started (a pool, a local cluster) and nothing it was given.
    """

    workers: int

    def map(self, function: Callable[[Any], Any], tasks: Sequence[Any]) -> list[Any]: ...

    def close(self) -> None: ...


class InProcessExecutor:
    """Run the tasks one after the other in this process (vectorised inside each task)."""

    workers = 1

    def map(self, function, tasks):
        return [function(task) for task in tasks]

    def close(self) -> None:
        """Nothing to release."""

    def __repr__(self) -> str:
        return "InProcessExecutor()"


class ProcessPoolExecutor:
    """Run the tasks on a local pool of worker processes.

    Parameters
    ----------
    workers : int, optional
        Number of processes; ``os.cpu_count()`` by default.
    mp_context : multiprocessing context or str, optional
        Start method ("fork", "forkserver", "spawn"); the platform default otherwise.
        With "spawn" and "forkserver" the model and inputs must be importable by name.

    Notes
    -----
    Each worker limits its native thread pools (OpenBLAS, OpenMP) to one thread when it
    starts (:func:`mtmetrology._backend.pin_one_thread`): n workers each running the
    library default of one BLAS thread per core would put n × cores threads on the cores,
    and OpenBLAS threads that wait for a busy core spin (on a 2-core machine, 2 workers at
    2 BLAS threads ran the SAMBA Monte Carlo 2.4× slower than at 1 when the machine was
    otherwise nearly idle, 3–6× when it was shared; bench/bench_samba.py ``--before``).
    The pool starts on the first ``map`` and is reused until ``close`` (the adaptive
    procedure calls ``map`` once per batch of sequences). The model and the input sampler
    are pickled with every task (:func:`monte_carlo` sends its chunks in two batches per
    worker, so once per batch), so they must be module-level functions or instances of
    module-level classes.
    """

    def __init__(self, workers: int | None = None, mp_context=None):
        count = (os.cpu_count() or 1) if workers is None else int(workers)
        if count < 1:
            raise ValueError(f"workers must be at least 1, got {workers}")
        self.workers = count
        self._context = (
            multiprocessing.get_context(mp_context) if isinstance(mp_context, str) else mp_context
        )
        self._pool: concurrent.futures.ProcessPoolExecutor | None = None

    def map(self, function, tasks):
        if self._pool is None:
            self._pool = concurrent.futures.ProcessPoolExecutor(
                max_workers=self.workers,
                mp_context=self._context,
                initializer=pin_one_thread,
            )
        return list(self._pool.map(function, tasks))

    def close(self) -> None:
        """Shut the pool down (it restarts on the next ``map``)."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)
            self._pool = None

    def __enter__(self):
        return self

    def __exit__(self, *exc_info):
        self.close()

    def __repr__(self) -> str:
        return f"ProcessPoolExecutor(workers={self.workers})"


class DaskExecutor:
    """Run the tasks on a Dask distributed cluster.

    Parameters
    ----------
    cluster : str or distributed.Client
        A scheduler address ("tcp://host:8786"), an existing ``distributed.Client``
        (used as is, never closed here), or ``"dask-local"`` to start a local cluster of
        ``workers`` single-threaded in-process workers, which this executor closes.
    workers : int
        Workers of the ``"dask-local"`` cluster.

    Notes
    -----
    Tasks are submitted with ``pure=False`` (no hashing of the model) and gathered in task
    order. The local cluster uses threads (``processes=False``): it starts in about a
    second and needs no importable model, at the price of sharing the GIL, which numpy
    releases in its array loops.
    """

    def __init__(self, cluster, workers: int = 2):
        try:
            import distributed
        except ImportError as error:  # pragma: no cover - dask is a declared dependency
            raise ImportError("the Dask executor needs dask[distributed] installed") from error
        self._owned: list[Any] = []
        if isinstance(cluster, distributed.Client):
            self.client = cluster
        elif cluster == "dask-local":
            if int(workers) < 1:
                raise ValueError(f"workers must be at least 1, got {workers}")
            local = distributed.LocalCluster(
                n_workers=int(workers),
                threads_per_worker=1,
                processes=False,
                dashboard_address=None,
            )
            self.client = distributed.Client(local)
            self._owned = [self.client, local]
        elif isinstance(cluster, str):
            self.client = distributed.Client(cluster)
            self._owned = [self.client]
        else:
            raise TypeError(
                "cluster must be a scheduler address, 'dask-local' or a distributed.Client, "
                f"got {type(cluster).__name__}"
            )
        self.workers = max(1, sum(self.client.nthreads().values()))

    def map(self, function, tasks):
        futures = self.client.map(function, list(tasks), pure=False)
        return self.client.gather(futures)

    def close(self) -> None:
        """Close the client and the local cluster if this executor started them."""
        for resource in self._owned:
            resource.close()
        self._owned = []

    def __repr__(self) -> str:
        return f"DaskExecutor({self.client.scheduler.address!r}, workers={self.workers})"


def resolve_executor(spec=None) -> tuple[Executor, bool]:
    """An executor from a user's choice, and whether the caller must close it.

    Parameters
    ----------
    spec : None, str, int, distributed.Client or Executor
        ``None`` or ``"inprocess"``: :class:`InProcessExecutor`. An int n or ``"processes"``
        (all cores) or ``"processes:n"``: a local :class:`ProcessPoolExecutor`.
        ``"dask-local"`` or ``"dask-local:n"``: a local Dask cluster of n workers (2 by
        default). Any other string is a Dask scheduler address. A ``distributed.Client``:
        that client. An object with ``workers``, ``map`` and ``close``: used as is.

    Returns
    -------
    (Executor, bool)
        The executor and True if it was created here (the caller closes it).

    Raises
    ------
    ValueError, TypeError
        For a malformed specification.
    """
    if spec is None or spec == "inprocess":
        return InProcessExecutor(), True
    if isinstance(spec, Executor):
        return spec, False
    if isinstance(spec, bool):
        raise TypeError("executor must be None, a name, a worker count or an executor object")
    if isinstance(spec, int):
        return ProcessPoolExecutor(spec), True
    if isinstance(spec, str):
        name, _, count = spec.partition(":")
        if name in ("processes", "dask-local") and "//" not in spec:
            if count and not count.isdigit():
                raise ValueError(f"executor {spec!r}: the worker count must be an integer")
            if name == "processes":
                return ProcessPoolExecutor(int(count) if count else None), True
            return DaskExecutor("dask-local", int(count) if count else 2), True
        return DaskExecutor(spec), True
    try:
        import distributed
    except ImportError:  # pragma: no cover
        distributed = None
    if distributed is not None and isinstance(spec, distributed.Client):
        return DaskExecutor(spec), True
    raise TypeError(
        f"executor must be None, 'inprocess', 'processes[:n]', 'dask-local[:n]', a scheduler "
        f"address, a worker count, a distributed.Client or an executor object, "
        f"got {type(spec).__name__}"
    )
