"""No module of the package imports another module's private name (issue 20).

A name beginning with one underscore (not a dunder) is private to the module that defines
it: what two modules share is promoted to a public, documented name.  Read from the
source with ``ast``: ``from mtmetrology.x import _name`` (also in multi-line lists and
inside functions) and ``alias._name`` on an alias bound to a package module by
``import mtmetrology.x as alias`` or ``from mtmetrology import x``.  A private *module*
(``kinematics/_sparse3.py``, ``cli/_common.py``) is private to its package: its own
package may import it, other packages may not.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PACKAGE = SRC / "mtmetrology"


def _module_name(path: Path) -> str:
    parts = path.relative_to(SRC).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _package_of(path: Path, module: str) -> str:
    return module if path.name == "__init__.py" else module.rpartition(".")[0]


def _is_private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _is_module(dotted: str) -> bool:
    rel = Path(*dotted.split("."))
    return (SRC / rel).with_suffix(".py").is_file() or (SRC / rel / "__init__.py").is_file()


def _private_part(importer: str, dotted: str) -> str | None:
    """The first private component of module path ``dotted`` that ``importer`` may not
    reach: a private module outside the importer's own package."""
    parts = dotted.split(".")
    for i, part in enumerate(parts):
        if _is_private(part):
            owner = ".".join(parts[:i])
            if importer != owner and not importer.startswith(owner + "."):
                return part
    return None


def violations(path: Path) -> list[str]:
    """Each private name ``path`` imports from (or reads off) another package module."""
    module = _module_name(path)
    package = _package_of(path, module)
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    found: list[str] = []
    aliases: dict[str, str] = {}  # local name -> package module it is bound to
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            if source.split(".")[0] != "mtmetrology":
                continue
            hidden = _private_part(module, source)
            if hidden:
                found.append(f"{module}:{node.lineno}: imports {source} (private {hidden})")
            for alias in node.names:
                target = f"{source}.{alias.name}"
                if _is_module(target):
                    aliases[alias.asname or alias.name] = target
                    hidden = _private_part(module, target)
                    if hidden and not _private_part(module, source):
                        found.append(f"{module}:{node.lineno}: imports module {target}")
                elif _is_private(alias.name):
                    found.append(f"{module}:{node.lineno}: imports {alias.name} from {source}")
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] != "mtmetrology":
                    continue
                if alias.asname:
                    aliases[alias.asname] = alias.name
                hidden = _private_part(module, alias.name)
                if hidden:
                    found.append(f"{module}:{node.lineno}: imports {alias.name}")
    for node in ast.walk(tree):
        if (
            isinstance(node, ast.Attribute)
            and isinstance(node.value, ast.Name)
            and node.value.id in aliases
            and _is_private(node.attr)
            and not _is_module(f"{aliases[node.value.id]}.{node.attr}")
        ):
            found.append(f"{module}:{node.lineno}: reads {node.attr} of {aliases[node.value.id]}")
    return found


MODULES = sorted(PACKAGE.rglob("*.py"))


@pytest.mark.parametrize("path", MODULES, ids=lambda p: _module_name(p))
def test_no_private_name_is_imported_from_another_module(path):
    assert violations(path) == []


def test_the_check_finds_each_kind_of_private_import(tmp_path, monkeypatch):
    """The check can fail: a module importing another's private name (one-line and
    multi-line lists, relative, inside a function), a private module of another package
    and an alias's private attribute are each reported; its own package's private module
    and a public name are not."""
    src = tmp_path / "src"
    pkg = src / "mtmetrology"
    (pkg / "a").mkdir(parents=True)
    (pkg / "b").mkdir()
    for f in ("__init__.py", "a/__init__.py", "b/__init__.py", "a/_hidden.py", "b/mod.py"):
        (pkg / f).write_text("")
    (pkg / "a" / "user.py").write_text(
        "from mtmetrology.a import _hidden\n"  # own package's private module: allowed
        "from mtmetrology.b.mod import public\n"
        "from mtmetrology.b.mod import (\n    public2,\n    _one,\n)\n"
        "from ..b.mod import _two\n"
        "def f():\n    from mtmetrology.b.mod import _three\n"
        "import mtmetrology.b.mod as m\n"
        "x = m._four\n"
    )
    (pkg / "b" / "user.py").write_text("from mtmetrology.a import _hidden\n")
    monkeypatch.setattr(__import__(__name__), "SRC", src)
    found = violations(pkg / "a" / "user.py")
    assert [line.split(": ", 1)[1] for line in found] == [
        "imports _one from mtmetrology.b.mod",
        "imports _two from mtmetrology.b.mod",
        "imports _three from mtmetrology.b.mod",
        "reads _four of mtmetrology.b.mod",
    ]
    assert violations(pkg / "b" / "user.py") == [
        "mtmetrology.b.user:1: imports module mtmetrology.a._hidden"
    ]
