"""Dimensional check of measurement-model outputs against their declared units.

An output declared ``unit: rad`` whose expression is a length in nm would be reported
with a wrong unit, and a sum of a length and a temperature is no quantity at all.  The
dimension of every node of the expression graph is derived from the units of the inputs
(:func:`mtmetrology.units.parse_unit`) with the rules of quantity calculus (JCGM 200:2012,
VIM 1.7):

- ``a + b``, ``a - b``, ``hypot(a, b)``, ``arctan2(a, b)``: a and b of one dimension;
- ``a * b``, ``a / b``: dimensions multiply and divide; ``a ** c`` needs a constant c when
  a has a dimension (the exponents are multiplied by c); ``sqrt`` halves them;
- ``exp``, ``log``, trigonometric and hyperbolic functions take a dimensionless argument
  (plane angles count as dimensionless, as in the SI: ``rad = 1``) and return one;
- a bare number takes the dimension its place requires (``theta - 20`` with theta in
  °C), so constants never raise a false alarm.

Only dimensions are checked, not scales: ``l_s + d`` with l_s in mm and d in nm has the
dimension of a length; the expression works in the units the inputs declare.

Examples
--------
>>> from mtmetrology.uncertainty.expressions import compile_expressions
>>> model = compile_expressions(["l", "a", "t"], [("y", "l * (1 + a * t)")])
>>> check_output_units(model, ["nm", "/°C", "°C"], ["mm"], "m.yaml")  # a length: fine
>>> try:  # doctest: +ELLIPSIS
...     check_output_units(model, ["nm", "/°C", "°C"], ["rad"], "m.yaml")
... except ModelFileError as err:
...     print(err)
m.yaml: outputs.0 ('y'): unit 'rad' is dimensionless but the expression is length ...
"""

from __future__ import annotations

from collections.abc import Sequence
from fractions import Fraction

from mtmetrology.uncertainty.expressions import (
    Binary,
    Call,
    CompiledModel,
    Const,
    ModelFileError,
    Neg,
    Node,
    Var,
    topological,
)
from mtmetrology.units import parse_unit

__all__ = ["Dimension", "check_output_units"]

# Dimensions of mtmetrology.units that are base quantities here; angle and ratio are 1.
_BASES = ("length", "temperature", "time", "pressure")
_DIMENSIONLESS_FUNCTIONS = frozenset(
    "exp log log10 log1p expm1 sin cos tan arcsin arccos arctan sinh cosh tanh "
    "radians degrees".split()
)


class Dimension:
    """Exponents of the base quantities; ``Dimension.FREE`` is a bare number's."""

    __slots__ = ("exponents",)
    FREE: Dimension

    def __init__(self, exponents: Sequence[Fraction] | None):
        self.exponents = None if exponents is None else tuple(Fraction(e) for e in exponents)

    @classmethod
    def of_unit(cls, symbol: str) -> Dimension:
        """The dimension of a unit string (``"µm/m"`` -> 1, ``"/°C"`` -> temperature⁻¹)."""
        text = parse_unit(symbol).dimension
        num, _, den = text.partition("/")
        den, _, power = den.partition("^")
        exps = [Fraction(0)] * len(_BASES)
        if num in _BASES:
            exps[_BASES.index(num)] += 1
        if den in _BASES:
            exps[_BASES.index(den)] -= int(power or 1)
        return cls(exps)

    @property
    def free(self) -> bool:
        return self.exponents is None

    @property
    def dimensionless(self) -> bool:
        return self.exponents is not None and not any(self.exponents)

    def times(self, other: Dimension, sign: int = 1) -> Dimension:
        if self.free and other.free:
            return Dimension.FREE
        a = self.exponents or (Fraction(0),) * len(_BASES)
        b = other.exponents or (Fraction(0),) * len(_BASES)
        return Dimension([x + sign * y for x, y in zip(a, b, strict=True)])

    def power(self, p: Fraction) -> Dimension:
        return self if self.free else Dimension([e * p for e in self.exponents])

    def same(self, other: Dimension) -> bool:
        return self.free or other.free or self.exponents == other.exponents

    def __str__(self) -> str:
        if self.free or self.dimensionless:
            return "dimensionless"
        parts = []
        for base, e in zip(_BASES, self.exponents, strict=True):
            if e:
                parts.append(base if e == 1 else f"{base}^{e}")
        return "·".join(parts)


Dimension.FREE = Dimension(None)


def _combine(node: Node, dims: dict[int, Dimension], units: Sequence[Dimension]) -> Dimension:
    """The dimension of one node from those of its children; ValueError if it has none."""
    if isinstance(node, Const):
        return Dimension.FREE
    if isinstance(node, Var):
        return units[node.index]
    if isinstance(node, Neg):
        return dims[id(node.operand)]
    if isinstance(node, Binary):
        a, b = dims[id(node.left)], dims[id(node.right)]
        if node.op in "+-":
            if not a.same(b):
                raise ValueError(f"'{node.op}' between a {a} and a {b} quantity")
            return b if a.free else a
        if node.op == "*":
            return a.times(b)
        if node.op == "/":
            return a.times(b, -1)
        if not (b.free or b.dimensionless):
            raise ValueError(f"an exponent must be dimensionless, not a {b} quantity")
        if a.free or a.dimensionless:
            return a
        if not isinstance(node.right, Const):
            raise ValueError(f"a {a} quantity raised to a variable power has no dimension")
        return a.power(Fraction(node.right.value).limit_denominator(1000))
    if isinstance(node, Call):
        args = [dims[id(x)] for x in node.args]
        if node.func in _DIMENSIONLESS_FUNCTIONS:
            if not (args[0].free or args[0].dimensionless):
                raise ValueError(
                    f"{node.func}() of a {args[0]} quantity (needs a dimensionless one)"
                )
            return args[0]  # free stays free, dimensionless stays dimensionless
        if node.func == "sign":
            return Dimension.FREE if args[0].free else Dimension([0] * len(_BASES))
        if node.func in ("hypot", "arctan2"):
            if not args[0].same(args[1]):
                raise ValueError(f"{node.func}() of a {args[0]} and a {args[1]} quantity")
            both = args[1] if args[0].free else args[0]
            return both if node.func == "hypot" else Dimension([0] * len(_BASES))
        if node.func == "sqrt":
            return args[0].power(Fraction(1, 2))
        if node.func == "square":
            return args[0].power(Fraction(2))
        return args[0]  # abs
    raise TypeError(f"unknown node {node!r}")  # pragma: no cover


def check_output_units(
    model: CompiledModel,
    input_units: Sequence[str],
    output_units: Sequence[str | None],
    source: str,
) -> None:
    """Refuse outputs whose expression is not of the dimension of their declared unit.

    Every operation of every output must have a dimension; an output whose unit is
    None (not declared in the file) is not compared.

    Raises
    ------
    ModelFileError
        Naming the file, the output, the declared unit and the dimension found.
    """
    names = model.output_names
    units = [Dimension.of_unit(u) for u in input_units]
    dims: dict[int, Dimension] = {}
    for j, tree in enumerate(model.trees):
        for node in topological([tree]):
            if id(node) in dims:
                continue
            try:
                dims[id(node)] = _combine(node, dims, units)
            except ValueError as exc:
                raise ModelFileError(
                    f"{source}: outputs.{j} ({names[j]!r}): {exc}; check the input units"
                ) from None
        if output_units[j] is None:
            continue
        found, declared = dims[id(tree)], Dimension.of_unit(output_units[j])
        if not found.same(declared):
            raise ModelFileError(
                f"{source}: outputs.{j} ({names[j]!r}): unit {output_units[j]!r} is "
                f"{declared} but the expression is {found} (from the input units)"
            )
