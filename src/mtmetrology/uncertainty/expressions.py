"""Safe measurement-model expressions: parsed with :mod:`ast`, never ``eval``.

Expressions are a safe subset of Python compiled to a tree of nodes evaluated over numpy
arrays: numbers, the names of inputs and of earlier outputs, ``pi`` and ``e``,
``+ - * / **``, unary minus, and calls of the whitelisted functions in
:data:`FUNCTIONS`.  Attribute access, subscripts, keyword arguments, comparisons and any
other construct are refused with an error naming the file, the output and the offending
token.

The compiled model is vectorised (X of shape (..., N) -> (..., m)), carries an analytic
Jacobian obtained by symbolic differentiation of the expression tree, and pickles as its
source text (rebuilt on unpickling), so process pools and Dask workers can run it.
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
    """A node of a compiled expression; ``evaluate(values)`` works on numpy arrays."""

    __slots__ = ()

    def evaluate(self, values: Sequence[np.ndarray]):  # pragma: no cover - abstract
        raise NotImplementedError


@dataclass(frozen=True, slots=True)
class Const(Node):
    value: float

    def evaluate(self, values):
        return self.value


@dataclass(frozen=True, slots=True)
class Var(Node):
    index: int
    name: str

    def evaluate(self, values):
        return values[self.index]


@dataclass(frozen=True, slots=True)
class Neg(Node):
    operand: Node

    def evaluate(self, values):
        return -self.operand.evaluate(values)


@dataclass(frozen=True, slots=True)
class Binary(Node):
    op: str
    left: Node
    right: Node

    def evaluate(self, values):
        a, b = self.left.evaluate(values), self.right.evaluate(values)
        if self.op == "+":
            return a + b
        if self.op == "-":
            return a - b
        if self.op == "*":
            return a * b
        if self.op == "/":
            return np.divide(a, b)
        return np.power(a, b)


@dataclass(frozen=True, slots=True)
class Call(Node):
    func: str
    args: tuple[Node, ...]

    def evaluate(self, values):
        return FUNCTIONS[self.func][0](*(a.evaluate(values) for a in self.args))


ZERO, ONE = Const(0.0), Const(1.0)


def _add(a: Node, b: Node) -> Node:
    if a == ZERO:
        return b
    if b == ZERO:
        return a
    if isinstance(a, Const) and isinstance(b, Const):
        return Const(a.value + b.value)
    return Binary("+", a, b)


def _sub(a: Node, b: Node) -> Node:
    if b == ZERO:
        return a
    if a == ZERO:
        return _neg(b)
    if isinstance(a, Const) and isinstance(b, Const):
        return Const(a.value - b.value)
    return Binary("-", a, b)


def _mul(a: Node, b: Node) -> Node:
    if a == ZERO or b == ZERO:
        return ZERO
    if a == ONE:
        return b
    if b == ONE:
        return a
    if isinstance(a, Const) and isinstance(b, Const):
        return Const(a.value * b.value)
    return Binary("*", a, b)


def _div(a: Node, b: Node) -> Node:
    if a == ZERO:
        return ZERO
    if b == ONE:
        return a
    return Binary("/", a, b)


def _neg(a: Node) -> Node:
    if isinstance(a, Const):
        return Const(-a.value)
    if isinstance(a, Neg):
        return a.operand
    return Neg(a)


def _pow(a: Node, b: Node) -> Node:
    if b == ONE:
        return a
    if b == ZERO:
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


def differentiate(node: Node, index: int) -> Node:
    """Symbolic derivative of ``node`` with respect to variable ``index``."""
    if isinstance(node, Const):
        return ZERO
    if isinstance(node, Var):
        return ONE if node.index == index else ZERO
    if isinstance(node, Neg):
        return _neg(differentiate(node.operand, index))
    if isinstance(node, Binary):
        a, b = node.left, node.right
        da, db = differentiate(a, index), differentiate(b, index)
        if node.op == "+":
            return _add(da, db)
        if node.op == "-":
            return _sub(da, db)
        if node.op == "*":
            return _add(_mul(da, b), _mul(a, db))
        if node.op == "/":
            # (a/b)' = (da·b − a·db)/b²
            return _div(_sub(_mul(da, b), _mul(a, db)), _pow(b, Const(2.0)))
        if db == ZERO:
            # Constant exponent: (a^b)' = b·a^(b−1)·da, valid for negative a too.
            return _mul(_mul(b, _pow(a, _sub(b, ONE))), da)
        # General power: (a^b)' = a^b·(db·ln a + b·da/a).
        return _mul(node, _add(_mul(db, _call("log", a)), _div(_mul(b, da), a)))
    if isinstance(node, Call):
        dargs = tuple(differentiate(arg, index) for arg in node.args)
        if all(d == ZERO for d in dargs):
            return ZERO
        return FUNCTIONS[node.func][2](node.args, dargs)
    raise TypeError(f"unknown node {node!r}")  # pragma: no cover - the compiler builds no others


# --------------------------------------------------------------------------- compiler


_BINOPS = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}


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
        try:
            tree = ast.parse(expression.strip(), mode="eval")
        except SyntaxError as exc:
            raise self.fail(None, f"syntax error in {expression!r}: {exc.msg}") from None
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
            return Const(float(node.value))
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
                return Const(float(Binary(op, left, right).evaluate(())))
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
        n = len(st["input_names"])
        self._derivatives = tuple(tuple(differentiate(t, i) for i in range(n)) for t in trees)

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
            vals = [np.broadcast_to(t.evaluate(cols), batch) for t in self._trees]
        return np.stack(vals, axis=-1)

    def jacobian(self, x) -> np.ndarray:
        """Analytic sensitivities ∂Y_j/∂X_i: x (..., N) -> (..., m, N)."""
        cols, batch = self._columns(x)
        with np.errstate(all="ignore"):
            rows = [
                np.stack([np.broadcast_to(d.evaluate(cols), batch) for d in drow], axis=-1)
                for drow in self._derivatives
            ]
        return np.stack(rows, axis=-2)

    def __repr__(self) -> str:
        outs = ", ".join(f"{n} = {e}" for n, e in self._state["outputs"])
        return f"CompiledModel({outs})"


def compile_expressions(input_names, outputs, output_units=None, source="<model>"):
    """Compile ``[(name, expression), ...]`` over ``input_names`` into a :class:`CompiledModel`."""
    return CompiledModel(input_names, outputs, output_units, source)
