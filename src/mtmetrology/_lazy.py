"""Names a package exports from its modules, imported on first use (PEP 562).

A package lists ``name -> module`` and gets the module-level ``__getattr__`` and
``__dir__`` that import a module only when one of its names is asked for, so importing
the package (or one of its modules) does not import the others::

    __getattr__, __dir__ = lazy_exports(__name__, {"Machine": "mtmetrology.kinematics.machine"})
"""

from __future__ import annotations

import importlib
import sys
import types
from collections.abc import Callable, Mapping

__all__ = ["LazyPackage", "lazy_exports"]


class LazyPackage(types.ModuleType):
    """A package whose exported names keep their meaning when a module of the same name loads.

    The import system binds every submodule to its package's attribute once it has loaded
    it (``setattr(package, "calibrate", <module>)``).  Where a package exports a function
    under its module's name (``samba.calibrate`` from ``samba/calibrate.py``), that binding
    would make ``from mtmetrology.samba import calibrate`` return the module or the
    function depending on what was imported first; the binding is skipped instead, and
    the module stays reachable through ``sys.modules`` and ``from … import``.
    """

    def __setattr__(self, name: str, value: object) -> None:
        exports = self.__dict__.get("_lazy_exports", ())
        if (
            name in exports
            and isinstance(value, types.ModuleType)
            and value.__name__ == f"{self.__name__}.{name}"
        ):
            return
        super().__setattr__(name, value)


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

    module = sys.modules[package]
    module._lazy_exports = frozenset(table)
    module.__class__ = LazyPackage
    for name in table:  # a module of an exported name already loaded by the package itself
        value = module.__dict__.get(name)
        if isinstance(value, types.ModuleType) and value.__name__ == f"{package}.{name}":
            del module.__dict__[name]
    return __getattr__, __dir__
