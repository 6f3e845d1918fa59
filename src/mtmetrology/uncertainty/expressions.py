"""Safe measurement-model expressions: parsed with :mod:`ast`, never ``eval``.

Expressions are a safe subset of Python compiled to a graph of nodes evaluated over numpy
arrays: numbers, the names of inputs and of earlier outputs, ``pi`` and ``e``,
``+ - * / **``, unary minus, and calls of the whitelisted functions in
:data:`FUNCTIONS`.  Attribute access, subscripts, keyword arguments, comparisons and any
other construct are refused with an error naming the file, the output and the offending
token.

The compiled model is vectorised (X of shape (..., N) -> (..., m)), carries an analytic
Jacobian obtained by symbolic differentiation of the expression graph, and pickles as its
source text (rebuilt on unpickling), so process pools and Dask workers can run it.

An output used by later outputs is one shared node of the graph: it is evaluated (and
differentiated) once per call, however many outputs refer to it, so a chain of outputs
each reusing the previous one twice costs linear, not exponential, time.  Expressions
are bounded (:data:`MAX_EXPRESSION_LENGTH` characters, :data:`MAX_DEPTH` levels,
:data:`MAX_NODES` operations for the whole model): beyond, the model is refused with a
message that says to define intermediate outputs.
"""

from __future__ import annotations

import ast
import keyword
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from mtmetrology.io import InputFileError

__all__ = [
    "CONSTANTS",
    "FUNCTIONS",
    "CompiledModel",
    "ExpressionError",
    "ModelFileError",
    "check_identifier",
    "compile_expressions",
]


class ModelFileError(InputFileError):
    """A model file that cannot be used; the message names the file and the field."""


class ExpressionError(ModelFileError):
    """An output expression outside the safe subset; names file, output and token."""


# --------------------------------------------------------------------------- expression tree


class Node:
    """A node of a compiled expression graph.

    Nodes compare and hash by identity: an output reused by later outputs is one shared
    node, evaluated once (:class:`_Program`), however often it is referred to.
    """

    __slots__ = ()

    def children(self) -> tuple[Node, ...]:
        return ()

    def apply(self, columns: Sequence[np.ndarray], args: list):  # pragma: no cover
        raise NotImplementedError


@dataclass(frozen=True, slots=True, eq=False)
class Const(Node):
    value: float

    def apply(self, columns, args):
        return self.value


@dataclass(frozen=True, slots=True, eq=False)
class Var(Node):
    index: int
    name: str

    def apply(self, columns, args):
        return columns[self.index]


@dataclass(frozen=True, slots=True, eq=False)
class Neg(Node):
    operand: Node

    def children(self):
        return (self.operand,)

    def apply(self, columns, args):
        return -args[0]


@dataclass(frozen=True, slots=True, eq=False)
class Binary(Node):
    op: str
    left: Node
    right: Node

    def children(self):
        return (self.left, self.right)

    def apply(self, columns, args):
        a, b = args
        if self.op == "+":
            return a + b
        if self.op == "-":
            return a - b
        if self.op == "*":
            return a * b
        if self.op == "/":
            return np.divide(a, b)
        return np.power(a, b)


@dataclass(frozen=True, slots=True, eq=False)
class Call(Node):
    func: str
    args: tuple[Node, ...]

    def children(self):
        return self.args

    def apply(self, columns, args):
        return FUNCTIONS[self.func][0](*args)


def _is(node: Node, value: float) -> bool:
    return isinstance(node, Const) and node.value == value


def topological(roots: Sequence[Node]) -> list[Node]:
    """Every distinct node reachable from ``roots``, children before parents (iterative:
    graphs deeper than Python's recursion limit are fine)."""
    order: list[Node] = []
    seen: set[int] = set()
    for root in roots:
        stack: list[tuple[Node, bool]] = [(root, False)]
        while stack:
            node, expanded = stack.pop()
            if expanded:
                order.append(node)
                continue
            if id(node) in seen:
                continue
            seen.add(id(node))
            stack.append((node, True))
            stack.extend((c, False) for c in reversed(node.children()) if id(c) not in seen)
    return order


class _Program:
    """A graph flattened into steps: each node evaluated once, each intermediate array
    released after its last use (memory stays bounded on large chunks of trials)."""

    def __init__(self, roots: Sequence[Node]):
        order = topological(roots)
        index = {id(n): k for k, n in enumerate(order)}
        self.steps = [(n, tuple(index[id(c)] for c in n.children())) for n in order]
        self.roots = [index[id(r)] for r in roots]
        last = {a: k for k, (_, args) in enumerate(self.steps) for a in args}
        keep = set(self.roots)
        self.release: list[list[int]] = [[] for _ in self.steps]
        for a, k in last.items():
            if a not in keep:
                self.release[k].append(a)

    def run(self, columns: Sequence[np.ndarray]) -> list:
        values: list = [None] * len(self.steps)
        for k, (node, args) in enumerate(self.steps):
            values[k] = node.apply(columns, [values[a] for a in args])
            for a in self.release[k]:
                values[a] = None
        return [values[r] for r in self.roots]


ZERO, ONE = Const(0.0), Const(1.0)


def _add(a: Node, b: Node) -> Node:
    if _is(a, 0.0):
        return b
    if _is(b, 0.0):
        return a
    if isinstance(a, Const) and isinstance(b, Const):
        return Const(a.value + b.value)
    return Binary("+", a, b)


def _sub(a: Node, b: Node) -> Node:
    if _is(b, 0.0):
        return a
    if _is(a, 0.0):
        return _neg(b)
    if isinstance(a, Const) and isinstance(b, Const):
        return Const(a.value - b.value)
    return Binary("-", a, b)


def _mul(a: Node, b: Node) -> Node:
    if _is(a, 0.0) or _is(b, 0.0):
        return ZERO
    if _is(a, 1.0):
        return b
    if _is(b, 1.0):
        return a
    if isinstance(a, Const) and isinstance(b, Const):
        return Const(a.value * b.value)
    return Binary("*", a, b)


def _div(a: Node, b: Node) -> Node:
    if _is(a, 0.0):
        return ZERO
    if _is(b, 1.0):
        return a
    return Binary("/", a, b)


def _neg(a: Node) -> Node:
    if isinstance(a, Const):
        return Const(-a.value)
    if isinstance(a, Neg):
        return a.operand
    return Neg(a)


def _pow(a: Node, b: Node) -> Node:
    if _is(b, 1.0):
        return a
    if _is(b, 0.0):
        return ONE
    return Binary("**", a, b)


def _call(name: str, *args: Node) -> Node:
    return Call(name, tuple(args))


_LN10 = math.log(10.0)

# name -> (numpy function, arity, derivative rule(args, dargs) -> Node)
FUNCTIONS: dict[str, tuple[Callable, int, Callable[[tuple, tuple], Node]]] = {
    "sqrt": (np.sqrt, 1, lambda a, d: _div(d[0], _mul(Const(2.0), _call("sqrt", a[0])))),
    "exp": (np.exp, 1, lambda a, d: _mul(_call("exp", a[0]), d[0])),
    "log": (np.log, 1, lambda a, d: _div(d[0], a[0])),
    "log10": (np.log10, 1, lambda a, d: _div(d[0], _mul(Const(_LN10), a[0]))),
    "log1p": (np.log1p, 1, lambda a, d: _div(d[0], _add(ONE, a[0]))),
    "expm1": (np.expm1, 1, lambda a, d: _mul(_call("exp", a[0]), d[0])),
    "sin": (np.sin, 1, lambda a, d: _mul(_call("cos", a[0]), d[0])),
    "cos": (np.cos, 1, lambda a, d: _neg(_mul(_call("sin", a[0]), d[0]))),
    "tan": (np.tan, 1, lambda a, d: _div(d[0], _pow(_call("cos", a[0]), Const(2.0)))),
    "arcsin": (
        np.arcsin,
        1,
        lambda a, d: _div(d[0], _call("sqrt", _sub(ONE, _pow(a[0], Const(2.0))))),
    ),
    "arccos": (
        np.arccos,
        1,
        lambda a, d: _neg(_div(d[0], _call("sqrt", _sub(ONE, _pow(a[0], Const(2.0)))))),
    ),
    "arctan": (np.arctan, 1, lambda a, d: _div(d[0], _add(ONE, _pow(a[0], Const(2.0))))),
    "sinh": (np.sinh, 1, lambda a, d: _mul(_call("cosh", a[0]), d[0])),
    "cosh": (np.cosh, 1, lambda a, d: _mul(_call("sinh", a[0]), d[0])),
    "tanh": (
        np.tanh,
        1,
        lambda a, d: _mul(_sub(ONE, _pow(_call("tanh", a[0]), Const(2.0))), d[0]),
    ),
    "abs": (np.abs, 1, lambda a, d: _mul(_call("sign", a[0]), d[0])),
    "sign": (np.sign, 1, lambda a, d: ZERO),
    "square": (np.square, 1, lambda a, d: _mul(_mul(Const(2.0), a[0]), d[0])),
    "radians": (np.radians, 1, lambda a, d: _mul(Const(math.pi / 180.0), d[0])),
    "degrees": (np.degrees, 1, lambda a, d: _mul(Const(180.0 / math.pi), d[0])),
    "arctan2": (
        np.arctan2,
        2,
        lambda a, d: _div(
            _sub(_mul(a[1], d[0]), _mul(a[0], d[1])),
            _add(_pow(a[0], Const(2.0)), _pow(a[1], Const(2.0))),
        ),
    ),
    "hypot": (
        np.hypot,
        2,
        lambda a, d: _div(_add(_mul(a[0], d[0]), _mul(a[1], d[1])), _call("hypot", a[0], a[1])),
    ),
}

#: Named constants usable in expressions.
CONSTANTS: dict[str, float] = {"pi": math.pi, "e": math.e}


def differentiate(node: Node, index: int, memo: dict[int, Node] | None = None) -> Node:
    """Symbolic derivative of ``node`` with respect to variable ``index``.

    The derivative of every shared node is built once (``memo``, by node identity), so
    the derivative graph grows linearly with the expression graph, not with the tree it
    unfolds to.
    """
    memo = {} if memo is None else memo
    for n in topological([node]):
        if id(n) not in memo:
            memo[id(n)] = _derivative(n, index, memo)
    return memo[id(node)]


def _derivative(node: Node, index: int, memo: dict[int, Node]) -> Node:
    """The derivative of one node from those of its children (already in ``memo``)."""
    if isinstance(node, Const):
        return ZERO
    if isinstance(node, Var):
        return ONE if node.index == index else ZERO
    if isinstance(node, Neg):
        return _neg(memo[id(node.operand)])
    if isinstance(node, Binary):
        a, b = node.left, node.right
        da, db = memo[id(a)], memo[id(b)]
        if node.op == "+":
            return _add(da, db)
        if node.op == "-":
            return _sub(da, db)
        if node.op == "*":
            return _add(_mul(da, b), _mul(a, db))
        if node.op == "/":
            # (a/b)' = (da·b − a·db)/b²
            return _div(_sub(_mul(da, b), _mul(a, db)), _pow(b, Const(2.0)))
        if _is(db, 0.0):
            # Constant exponent: (a^b)' = b·a^(b−1)·da, valid for negative a too.
            return _mul(_mul(b, _pow(a, _sub(b, ONE))), da)
        # General power: (a^b)' = a^b·(db·ln a + b·da/a).
        return _mul(node, _add(_mul(db, _call("log", a)), _div(_mul(b, da), a)))
    if isinstance(node, Call):
        dargs = tuple(memo[id(arg)] for arg in node.args)
        if all(_is(d, 0.0) for d in dargs):
            return ZERO
        return FUNCTIONS[node.func][2](node.args, dargs)
    raise TypeError(f"unknown node {node!r}")  # pragma: no cover - the compiler builds no others


# --------------------------------------------------------------------------- compiler


_BINOPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}

#: Longest expression accepted (characters); real models are far shorter, and longer ones
#: are better split into named intermediate outputs.
MAX_EXPRESSION_LENGTH = 10_000
#: Deepest nesting of one expression (operators, calls, parentheses).
MAX_DEPTH = 200
#: Most distinct nodes of a model's expression graph (all outputs together).
MAX_NODES = 100_000


def _depth(tree: ast.AST) -> int:
    """Nesting depth of an AST, computed without recursion."""
    deepest, stack = 0, [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        stack.extend((c, depth + 1) for c in ast.iter_child_nodes(node))
    return deepest


class _Compiler:
    def __init__(self, input_names: Sequence[str], source: str):
        self.inputs = {n: i for i, n in enumerate(input_names)}
        self.outputs: dict[str, Node] = {}
        self.source = source
        self.output = ""

    def fail(self, node: ast.AST | None, problem: str) -> ExpressionError:
        where = (
            f" (column {node.col_offset + 1})"
            if node is not None and hasattr(node, "col_offset")
            else ""
        )
        return ExpressionError(f"{self.source}: output {self.output!r}: {problem}{where}")

    def compile(self, name: str, expression: str) -> Node:
        self.output = name
        if not isinstance(expression, str) or not expression.strip():
            raise self.fail(None, "expression must be a non-empty string")
        if len(expression) > MAX_EXPRESSION_LENGTH:
            raise self.fail(
                None,
                f"the expression has {len(expression)} characters, more than "
                f"{MAX_EXPRESSION_LENGTH}; define intermediate outputs",
            )
        try:
            tree = ast.parse(expression.strip(), mode="eval")
        except SyntaxError as exc:
            shown = expression if len(expression) <= 60 else expression[:57] + "..."
            raise self.fail(None, f"syntax error in {shown!r}: {exc.msg}") from None
        except (RecursionError, MemoryError):
            raise self.fail(
                None, f"nested deeper than {MAX_DEPTH} levels; define intermediate outputs"
            ) from None
        depth = _depth(tree)
        if depth > MAX_DEPTH:
            raise self.fail(
                None,
                f"nested {depth} levels deep, more than {MAX_DEPTH}; define intermediate outputs",
            )
        self.forbidden(tree)
        node = self.visit(tree.body)
        self.outputs[name] = node
        return node

    def forbidden(self, tree: ast.AST) -> None:
        """Name the most dangerous token first, wherever it is nested (``__import__``...)."""
        for node in ast.walk(tree):
            if isinstance(node, ast.Name) and node.id.startswith("__"):
                raise self.fail(node, f"name {node.id!r} is not allowed")
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
                if node.func.id not in FUNCTIONS:
                    raise self.fail(
                        node,
                        f"call to {node.func.id!r} is not allowed; "
                        f"allowed functions: {', '.join(FUNCTIONS)}",
                    )

    def visit(self, node: ast.AST) -> Node:
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, int | float):
                raise self.fail(node, f"constant {ast.unparse(node)} is not a real number")
            return self.constant(node, node.value)
        if isinstance(node, ast.Name):
            return self.name(node)
        if isinstance(node, ast.BinOp):
            op = _BINOPS.get(type(node.op))
            if op is None:
                raise self.fail(
                    node, f"operator in {ast.unparse(node)!r} is not allowed (use + - * / **)"
                )
            left, right = self.visit(node.left), self.visit(node.right)
            if isinstance(left, Const) and isinstance(right, Const):
                with np.errstate(all="ignore"):
                    value = Binary(op, left, right).apply((), [left.value, right.value])
                return self.constant(node, value)
            return Binary(op, left, right)
        if isinstance(node, ast.UnaryOp):
            if isinstance(node.op, ast.USub):
                return _neg(self.visit(node.operand))
            if isinstance(node.op, ast.UAdd):
                return self.visit(node.operand)
            raise self.fail(node, f"operator in {ast.unparse(node)!r} is not allowed")
        if isinstance(node, ast.Call):
            return self.call(node)
        if isinstance(node, ast.Attribute):
            raise self.fail(node, f"attribute access {ast.unparse(node)!r} is not allowed")
        if isinstance(node, ast.Subscript):
            raise self.fail(node, f"subscript {ast.unparse(node)!r} is not allowed")
        raise self.fail(
            node, f"{type(node).__name__} {ast.unparse(node)!r} is not allowed in an expression"
        )

    def constant(self, node: ast.AST, value: float) -> Const:
        """A finite constant (``1e400``, ``10**400`` or ``0/0`` are refused)."""
        try:
            v = float(value)
        except OverflowError:
            v = math.inf
        if not math.isfinite(v):
            raise self.fail(node, f"the constant {ast.unparse(node)} is not a finite number")
        return Const(v)

    def name(self, node: ast.Name) -> Node:
        n = node.id
        if n in self.inputs:
            return Var(self.inputs[n], n)
        if n in self.outputs:
            return self.outputs[n]  # earlier outputs are inlined (shared subtree)
        if n in CONSTANTS:
            return Const(CONSTANTS[n])
        if n in FUNCTIONS:
            raise self.fail(node, f"function {n!r} must be called")
        known = sorted([*self.inputs, *self.outputs, *CONSTANTS])
        raise self.fail(node, f"unknown name {n!r}; known names: {', '.join(known)}")

    def call(self, node: ast.Call) -> Node:
        if not isinstance(node.func, ast.Name):
            raise self.fail(
                node,
                f"call of {ast.unparse(node.func)!r} is not allowed; "
                f"allowed functions: {', '.join(FUNCTIONS)}",
            )
        fname = node.func.id
        if fname not in FUNCTIONS:
            raise self.fail(
                node, f"call to {fname!r} is not allowed; allowed functions: {', '.join(FUNCTIONS)}"
            )
        if node.keywords or any(isinstance(a, ast.Starred) for a in node.args):
            raise self.fail(node, f"{fname}() takes positional arguments only")
        arity = FUNCTIONS[fname][1]
        if len(node.args) != arity:
            raise self.fail(node, f"{fname}() takes {arity} argument(s), got {len(node.args)}")
        return Call(fname, tuple(self.visit(a) for a in node.args))


def check_identifier(name: str, what: str, source: str) -> None:
    if not isinstance(name, str) or not name.isidentifier() or keyword.iskeyword(name):
        raise ModelFileError(f"{source}: {what} name {name!r} is not a valid identifier")
    if name.startswith("__") or name in FUNCTIONS or name in CONSTANTS:
        raise ModelFileError(f"{source}: {what} name {name!r} is reserved")


class CompiledModel:
    """A vectorised measurement model compiled from output expressions.

    Parameters
    ----------
    input_names : sequence of str, length N
    outputs : sequence of (name, expression), length m
        Later outputs may use earlier ones.
    output_units : sequence of str, optional
    source : str
        File name used in error messages.

    Notes
    -----
    ``__call__`` maps X (..., N) to (..., m); ``jacobian`` maps x (..., N) to
    (..., m, N) from symbolic derivatives.  Pickling keeps only the source text.
    """

    def __init__(self, input_names, outputs, output_units=None, source: str = "<model>"):
        self._state = {
            "input_names": [str(n) for n in input_names],
            "outputs": [(str(n), str(e)) for n, e in outputs],
            "output_units": None if output_units is None else [str(u) for u in output_units],
            "source": str(source),
        }
        self._build()

    def _build(self) -> None:
        st = self._state
        src = st["source"]
        for n in st["input_names"]:
            check_identifier(n, "input", src)
        if not st["outputs"]:
            raise ModelFileError(f"{src}: a model needs at least one output")
        seen = set(st["input_names"])
        compiler = _Compiler(st["input_names"], src)
        trees = []
        for name, expression in st["outputs"]:
            check_identifier(name, "output", src)
            if name in seen:
                raise ModelFileError(f"{src}: output name {name!r} is already used")
            seen.add(name)
            trees.append(compiler.compile(name, expression))
        self._trees = tuple(trees)
        size = len(topological(trees))
        if size > MAX_NODES:
            raise ModelFileError(
                f"{src}: the outputs form a graph of {size} operations, more than {MAX_NODES}"
            )
        self._values = _Program(trees)
        self._gradient: _Program | None = None  # built on first use (GUF only needs it)

    @property
    def trees(self) -> tuple[Node, ...]:
        """The compiled expression graph of each output (shared nodes are shared)."""
        return self._trees

    def _jacobian_program(self) -> _Program:
        if self._gradient is None:
            n = len(self._state["input_names"])
            memos: list[dict[int, Node]] = [{} for _ in range(n)]
            rows = [differentiate(t, i, memos[i]) for t in self._trees for i in range(n)]
            self._gradient = _Program(rows)
        return self._gradient

    def __getstate__(self) -> dict:
        return self._state

    def __setstate__(self, state: dict) -> None:
        self._state = state
        self._build()

    @property
    def input_names(self) -> list[str]:
        return list(self._state["input_names"])

    @property
    def output_names(self) -> list[str]:
        return [n for n, _ in self._state["outputs"]]

    @property
    def expressions(self) -> list[str]:
        return [e for _, e in self._state["outputs"]]

    @property
    def output_units(self) -> list[str] | None:
        u = self._state["output_units"]
        return None if u is None else list(u)

    def _columns(self, x) -> tuple[list[np.ndarray], tuple[int, ...]]:
        x = np.asarray(x, dtype=float)
        n = len(self._state["input_names"])
        if x.shape[-1:] != (n,):
            raise ValueError(f"model expects X with last axis {n}, got shape {x.shape}")
        return [x[..., i] for i in range(n)], x.shape[:-1]

    def __call__(self, x) -> np.ndarray:
        """Evaluate the outputs: X (..., N) -> (..., m)."""
        cols, batch = self._columns(x)
        with np.errstate(all="ignore"):  # NaN/inf are reported by the caller, not warned
            vals = [np.broadcast_to(v, batch) for v in self._values.run(cols)]
        return np.stack(vals, axis=-1)

    def jacobian(self, x) -> np.ndarray:
        """Analytic sensitivities ∂Y_j/∂X_i: x (..., N) -> (..., m, N)."""
        cols, batch = self._columns(x)
        n = len(self._state["input_names"])
        with np.errstate(all="ignore"):
            flat = [np.broadcast_to(v, batch) for v in self._jacobian_program().run(cols)]
        rows = [np.stack(flat[j * n : (j + 1) * n], axis=-1) for j in range(len(self._trees))]
        return np.stack(rows, axis=-2)

    def __repr__(self) -> str:
        outs = ", ".join(f"{n} = {e}" for n, e in self._state["outputs"])
        return f"CompiledModel({outs})"


def compile_expressions(input_names, outputs, output_units=None, source="<model>"):
    """Compile ``[(name, expression), ...]`` over ``input_names`` into a :class:`CompiledModel`."""
    return CompiledModel(input_names, outputs, output_units, source)
