"""The curated top-level API: every name resolves to its engine's object, lazily."""

from __future__ import annotations

import importlib
import subprocess
import sys

import pytest

import mtmetrology


@pytest.mark.parametrize("name", mtmetrology.__all__)
def test_each_top_level_name_is_the_engine_object(name):
    module = importlib.import_module(mtmetrology._API[name])
    assert getattr(mtmetrology, name) is getattr(module, name)


def test_unknown_name_is_an_attribute_error():
    with pytest.raises(AttributeError, match="no attribute 'Machin'"):
        mtmetrology.Machin  # noqa: B018


def test_importing_the_package_loads_no_engine():
    """``import mtmetrology`` loads neither numpy nor any engine (only the leaf that makes
    its names lazy); a name loads its own module."""
    code = (
        "import sys, mtmetrology\n"
        "print(sorted(m for m in sys.modules if m.startswith('mtmetrology.') or m == 'numpy'))\n"
        "from mtmetrology import Machine\n"
        "print('mtmetrology.kinematics.machine' in sys.modules,"
        " 'mtmetrology.uncertainty' in sys.modules)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    first, second = done.stdout.splitlines()
    assert first == "['mtmetrology._lazy']" and second.split() == ["True", "False"]


def test_every_package_declares_all():
    import pkgutil

    for info in pkgutil.iter_modules(mtmetrology.__path__):
        if info.ispkg:
            package = importlib.import_module(f"mtmetrology.{info.name}")
            assert isinstance(getattr(package, "__all__", None), list | tuple), info.name


def test_all_lists_exactly_the_lazy_names():
    assert sorted(mtmetrology.__all__) == sorted(mtmetrology._API)


@pytest.mark.parametrize("package", ["io", "samba", "cmm", "design", "omm", "identification"])
def test_lazy_packages_export_what_they_list(package):
    """Every lazily exported name resolves, and __all__ lists them (and only public names)."""
    module = importlib.import_module(f"mtmetrology.{package}")
    for name in module.__all__:
        assert getattr(module, name) is not None
    exports = getattr(module, "_EXPORTS", None) or module._UNCERTAINTY
    assert set(exports) <= set(module.__all__)


def test_an_exported_name_keeps_its_meaning_after_its_module_loads():
    """``samba.calibrate`` (a function in ``samba/calibrate.py``) and ``design.detmax`` are
    the functions whatever was imported first: the import system's binding of a loaded
    submodule to the package attribute must not replace the export (fresh interpreter, the
    modules imported before the names are asked for)."""
    code = (
        "import importlib, types\n"
        "pairs = [('samba', 'calibrate'), ('design', 'detmax')]\n"
        "for pkg, name in pairs:\n"
        "    importlib.import_module(f'mtmetrology.{pkg}.{name}')\n"
        "for pkg, name in pairs:\n"
        "    value = getattr(importlib.import_module(f'mtmetrology.{pkg}'), name)\n"
        "    print(pkg, name, isinstance(value, types.ModuleType), callable(value))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.split("\n")
    assert out[:2] == ["samba calibrate False True", "design detmax False True"]


def test_the_module_of_an_exported_name_stays_importable():
    from mtmetrology.samba import calibrate

    module = importlib.import_module("mtmetrology.samba.calibrate")
    assert callable(calibrate) and module.calibrate is calibrate
