"""Names a package exports from its modules, imported on first use (PEP 562).

A package lists ``name -> module`` and gets the module-level ``__getattr__`` and
``__dir__`` that import a module only when one of its names is asked for, so importing
the package (or one of its modules) does not import the others::

    __getattr__, __dir__ = lazy_exports(__name__, {"Machine": "mtmetrology.kinematics.machine"})
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, table: Mapping[str, str]
) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` of ``package`` exporting ``table``'s names lazily.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    table : mapping of str to str
        Exported name -> the module that defines it.
    """

    def __getattr__(name: str) -> object:
        module = table.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        setattr(sys.modules[package], name, value)  # later look-ups skip __getattr__
        return value

    def __dir__() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(table))

    return __getattr__, __dir__
