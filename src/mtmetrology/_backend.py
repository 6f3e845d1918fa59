"""Which implementation runs the hot loops: compiled (numba) kernels or numpy.

``MTMETROLOGY_BACKEND=numba`` (the default) lets the kinematic chain and the batched
fits use their compiled kernels when numba is installed; ``MTMETROLOGY_BACKEND=numpy``
(any other value) keeps them on numpy.  Each engine copies the setting into its own
``BACKEND`` attribute at import, which may be changed at run time.  Kernel modules are
imported on first use only: numba takes about half a second to import.

Compiled kernels are cached on disk where numba can write (``cache=True``), so a later
process loads them in milliseconds; where it cannot (read-only install, no home
directory, a full disk), :func:`njit_cached` compiles them in memory for the process,
silently: a cache is an optimisation, never a reason to fail.

Native thread pools (OpenBLAS, OpenMP) are the other half of how the hot loops use the
cores: :func:`one_thread` runs a block with one thread per pool, for work on matrices too
small for threads to pay (a Monte Carlo chunk's few-hundred-row products and SVDs), and
:func:`pin_one_thread` keeps a worker process at one thread, so that n workers use n cores
instead of n × (threads per pool).
"""

from __future__ import annotations

import functools
import importlib
import os
from types import ModuleType


def from_environment() -> str:
    """The backend named by ``MTMETROLOGY_BACKEND`` (``"numba"`` if unset)."""
    return os.environ.get("MTMETROLOGY_BACKEND", "numba").strip().lower()


def njit_cached(**options):
    """``numba.njit(cache=True, **options)``, or ``njit(**options)`` where numba cannot cache.

    numba looks for a writable cache directory when the function is decorated
    (``NUMBA_CACHE_DIR``, the module's ``__pycache__``, the user's cache directory) and
    raises ``RuntimeError("cannot cache function ...: no locator available ...")`` when
    there is none; the kernel is then compiled in memory on first call instead.
    """
    from numba import njit

    def decorate(func):
        try:
            return njit(cache=True, **options)(func)
        except RuntimeError:
            return njit(**options)(func)

    return decorate


@functools.cache
def _thread_pools():
    """The native thread pools loaded now (threadpoolctl scans the libraries once)."""
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


def one_thread():
    """Context manager: every native thread pool (BLAS, OpenMP) limited to one thread,
    restored on exit.

    Costs about 10 µs (``threadpool_limits`` rescans the loaded libraries, 0.4 ms); pools
    loaded after the first call are not limited.

    Examples
    --------
    >>> import numpy as np
    >>> with one_thread():
    ...     float(np.ones((3, 3)) @ np.ones(3) @ np.ones(3))
    9.0
    """
    return _thread_pools().limit(limits=1)


def pin_one_thread() -> None:
    """Limit every native thread pool of this process to one thread for good (a process
    pool's worker initializer; it scans the libraries the worker has loaded)."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(1)


@functools.cache
def compiled_module(name: str) -> ModuleType | None:
    """The kernel module ``name``, or None when numba is not installed."""
    try:
        return importlib.import_module(name)
    except ImportError:
        return None
