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
def compiled_module(name: str) -> ModuleType | None:
    """The kernel module ``name``, or None when numba is not installed."""
    try:
        return importlib.import_module(name)
    except ImportError:
        return None
