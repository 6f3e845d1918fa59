"""Which implementation runs the hot loops: compiled (numba) kernels or numpy.

``MTMETROLOGY_BACKEND=numba`` (the default) lets the kinematic chain and the batched
fits use their compiled kernels when numba is installed; ``MTMETROLOGY_BACKEND=numpy``
(any other value) keeps them on numpy.  Each engine copies the setting into its own
``BACKEND`` attribute at import, which may be changed at run time.  Kernel modules are
imported on first use only: numba takes about half a second to import.
"""

from __future__ import annotations

import functools
import importlib
import os
from types import ModuleType


def from_environment() -> str:
    """The backend named by ``MTMETROLOGY_BACKEND`` (``"numba"`` if unset)."""
    return os.environ.get("MTMETROLOGY_BACKEND", "numba").strip().lower()


@functools.cache
def compiled_module(name: str) -> ModuleType | None:
    """The kernel module ``name``, or None when numba is not installed."""
    try:
        return importlib.import_module(name)
    except ImportError:
        return None
