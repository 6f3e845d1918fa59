"""The layers of the package, read from the source (ast): imports point downwards.

- engines (kinematics, uncertainty, fitting, identification, optimize, io, units, formatting, rng,
  errors, display, _lazy) import nothing from ``report``, ``cli`` or an application, not even
  inside a function;
- the leaf modules (display, _lazy) import nothing of the package;
- an application imports no other application;
- no import cycle between modules, counting the imports inside functions;
- ``cli/`` imports no numpy, scipy or matplotlib at module level (a command loads only
  what it runs).

Imports under ``if TYPE_CHECKING:`` are not executed and are not counted; an import of
one's own parent package (``from mtmetrology.kinematics import _sparse3`` inside
``kinematics``) is not an edge.
"""

from __future__ import annotations

import ast
from collections import defaultdict
from functools import cache
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
ENGINES = {
    "kinematics",
    "uncertainty",
    "fitting",
    "identification",
    "optimize",
    "io",
    "units",
    "formatting",
    "rng",
    "errors",
    "display",
    "_backend",
    "_memory",
    "_lazy",
}
APPLICATIONS = {
    "samba",
    "design",
    "omm",
    "cmm",
    "budgets",
    "tracker",
    "multilateration",
    "export",
    "history",
}
TOP_FLOOR = {"report", "cli"}
HEAVY = {"numpy", "scipy", "matplotlib", "jinja2", "dask", "sklearn"}

#: cli modules that still compute (numpy at module level); issue 20 moved their workflows
#: into library calls. The test fails if a listed module is clean.
CLI_NUMPY_PENDING: set[str] = set()
#: Import cycles still to be broken (none: the demo's sections became examples/ scripts).
CYCLES_PENDING: list[set[str]] = []


def _name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_name(p): p for p in SRC.rglob("*.py")}


def _type_checking(node: ast.AST) -> bool:
    test = getattr(node, "test", None)
    return isinstance(node, ast.If) and (
        (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING")
        or (isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")
    )


def _walk(nodes, top_level: bool):
    for node in nodes:
        if _type_checking(node):
            continue
        yield node
        if not top_level or isinstance(node, ast.If | ast.Try | ast.With):
            yield from _walk(ast.iter_child_nodes(node), top_level)


@cache
def imports(module: str, top_level: bool = False) -> tuple[tuple[str, int], ...]:
    """(imported module, line) of a module: executed at import time only, or anywhere."""
    path = MODULES[module]
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = []
    for node in _walk(ast.parse(path.read_text(encoding="utf-8")).body, top_level):
        if isinstance(node, ast.Import):
            found += [(a.name, node.lineno) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module
            subs = [f"{target}.{a.name}" for a in node.names if f"{target}.{a.name}" in MODULES]
            if len(subs) < len(node.names):
                found.append((target, node.lineno))
            found += [(s, node.lineno) for s in subs]
    own = {module.rsplit(".", k)[0] for k in range(1, module.count(".") + 1)}
    return tuple((m, line) for m, line in found if m not in own and m != module)


def _layer(module: str) -> str:
    return module.split(".")[1] if module.count(".") else ""


def _edges(kinds: set[str], targets: set[str]) -> list[str]:
    bad = []
    for module in sorted(MODULES):
        here = _layer(module)
        if here not in kinds:
            continue
        for target, line in imports(module):
            there = _layer(target) if target.startswith("mtmetrology.") else ""
            if there in targets and there != here:
                bad.append(f"{MODULES[module].relative_to(SRC)}:{line} imports {target}")
    return bad


def test_engines_import_no_report_cli_or_application():
    assert _edges(ENGINES, TOP_FLOOR | APPLICATIONS) == []


@pytest.mark.parametrize("leaf", ["mtmetrology.display", "mtmetrology._lazy"])
def test_leaf_modules_import_nothing_of_the_package(leaf):
    assert [t for t, _ in imports(leaf) if t.split(".")[0] == "mtmetrology"] == []


def test_applications_import_no_other_application():
    assert _edges(APPLICATIONS, APPLICATIONS) == []


def _cycles() -> list[set[str]]:
    """Strongly connected components of more than one module (Tarjan, iterative)."""
    graph = defaultdict(set)
    for module in MODULES:
        graph[module] = {t for t, _ in imports(module) if t in MODULES}
    index, low, stack, on_stack, found = {}, {}, [], set(), []
    for root in sorted(MODULES):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = set()
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.add(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(component)
    return found


def test_no_import_cycles():
    assert sorted(map(sorted, _cycles())) == sorted(map(sorted, CYCLES_PENDING))


def test_cycle_finder_finds_a_cycle(monkeypatch):
    """The finder itself: a two-module cycle planted in the graph is reported."""
    fake = {"mtmetrology.a": (("mtmetrology.b", 1),), "mtmetrology.b": (("mtmetrology.a", 1),)}
    monkeypatch.setitem(MODULES, "mtmetrology.a", SRC / "a.py")
    monkeypatch.setitem(MODULES, "mtmetrology.b", SRC / "b.py")
    real = imports

    def planted(module, top_level=False):
        return fake[module] if module in fake else real(module, top_level)

    monkeypatch.setattr(f"{__name__}.imports", planted)
    assert {"mtmetrology.a", "mtmetrology.b"} in _cycles()


@pytest.mark.parametrize(
    "module", sorted(m for m in MODULES if m.startswith("mtmetrology.cli")), ids=str
)
def test_cli_imports_no_numerical_stack_at_module_level(module):
    heavy = [(t, line) for t, line in imports(module, True) if t.split(".")[0] in HEAVY]
    if module in CLI_NUMPY_PENDING:
        assert heavy, f"{module} is clean: remove it from CLI_NUMPY_PENDING"
    else:
        assert heavy == []
