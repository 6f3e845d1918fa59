"""What every error parameter means: the sign convention and the reference point, in words.

Each parameter of a machine's error model gets a :class:`ParameterConvention`: its name and
unit, one line on what a positive value does to the tool relative to the workpiece, and
where it is referred to (a point in the machine frame at zero readings).  ``mtm machine
show`` prints these lines and the user documentation carries the same text, generated
from the same function, so the words cannot drift from the model.

The conventions themselves (ISO 230-1:2012 with the ISO 841 axis directions) are stated in
:mod:`mtmetrology.kinematics.chain`:

- an *error motion* ``E_XX1`` or reversal term ``E_XXb`` is a deviation of the tool
  relative to the workpiece, positive along the positive principal axis (rotations by the
  right-hand rule), whichever component moves; it is measured at the axis reference point
  (a point of the moving body) and, for rotations, acts about that point;
- a *location error* ``E_X0C`` / ``E_B0C`` is the position / orientation of the axis
  average line in the machine frame (parent axes at zero), displacing or turning the axis
  with what it carries about its reference point.

The reference point of axis k is its frame origin: the sum of the nominal offsets
``offset_mm`` from the frame F out to k, at zero readings.

Examples
--------
>>> from mtmetrology.kinematics import Machine
>>> m = Machine.load("five-axis-wcbxfzyst")
>>> c = describe_parameter(m, "E_XX1")
>>> c.positive
'the tool deviates by +E_XX1·x along +X relative to the workpiece (x in m)'
>>> describe_parameter(m, "E_X0S").reference
'S reference point (0, 0, 150) mm at zero readings (the stylus centre is at (0, 0, 0) mm)'
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameters import COMPONENTS, ErrorParameter, parse_parameter
from mtmetrology.kinematics.topology import LINEAR_AXES
from mtmetrology.units import from_internal

__all__ = [
    "ParameterConvention",
    "describe_parameter",
    "describe_parameters",
    "machine_description",
    "reference_point",
]

_DIRECTION = {"X": "+X", "Y": "+Y", "Z": "+Z", "A": "+X", "B": "+Y", "C": "+Z"}
_POSITION_SYMBOL = {"X": "x", "Y": "y", "Z": "z", "A": "a", "B": "b", "C": "c", "S": "s"}


@dataclass(frozen=True)
class ParameterConvention:
    """The meaning of one error parameter.

    Attributes
    ----------
    name, unit, kind : str
        ISO 230-1 name, customary unit, ``location`` / ``motion`` / ``reversal``.
    axis : str
        The axis it belongs to; ``side`` the branch (``tool`` or ``workpiece``).
    positive : str
        What a positive value does, one line.
    reference : str
        Where it is referred to, one line.
    reference_point_mm : tuple of float
        The axis reference point in the machine frame at zero readings.
    """

    name: str
    unit: str
    kind: str
    axis: str
    side: str
    positive: str
    reference: str
    reference_point_mm: tuple[float, float, float]

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "unit": self.unit,
            "kind": self.kind,
            "axis": self.axis,
            "side": self.side,
            "positive": self.positive,
            "reference": self.reference,
            "reference_point_mm": list(self.reference_point_mm),
        }


def reference_point(machine: Machine, axis: str) -> np.ndarray:
    """The reference point of ``axis`` in the machine frame at zero readings, mm.

    It is the sum of the nominal offsets from the frame F out to the axis (all motions are
    the identity at zero readings).
    """
    branch = (
        machine.topology.workpiece_axes
        if machine.topology.side(axis) == "workpiece"
        else machine.topology.tool_axes
    )
    point = np.zeros(3)
    for name in branch[: branch.index(axis) + 1]:
        point = point + machine.axes[name].offset
    return point


def _stylus_point(machine: Machine) -> np.ndarray:
    """The stylus centre in the machine frame at zero readings, mm."""
    point = np.array(machine.tool, dtype=float)
    for name in machine.topology.tool_axes:
        point = point + machine.axes[name].offset
    return point


def _fmt(point: np.ndarray) -> str:
    return "(" + ", ".join(f"{v + 0.0:.6g}" for v in point) + ")"


def _basis_term(machine: Machine, p: ErrorParameter) -> str:
    """``x`` (monomial, m), ``P_2(u_x)`` (Legendre on the normalised travel) ..."""
    basis = machine.axes[p.axis].basis
    symbol = _POSITION_SYMBOL[p.axis]
    if p.degree == 0:
        return ""
    if basis.kind == "monomial" and not basis.normalised:
        return f"·{symbol}" if p.degree == 1 else f"·{symbol}^{p.degree}"
    letter = {"monomial": "", "legendre": "P", "chebyshev": "T"}[basis.kind]
    if letter:
        return f"·{letter}_{p.degree}(u_{symbol})"
    return f"·u_{symbol}^{p.degree}"


def _position_unit(machine: Machine, p: ErrorParameter) -> str:
    basis = machine.axes[p.axis].basis
    if p.kind != "motion" or p.degree == 0:
        return ""
    if basis.normalised:
        return f" (u_{_POSITION_SYMBOL[p.axis]} the position normalised on the travel to [-1, 1])"
    return f" ({_POSITION_SYMBOL[p.axis]} in {'m' if p.axis in LINEAR_AXES else 'rad'})"


def describe_parameter(machine: Machine, name: str) -> ParameterConvention:
    """The convention of one catalogue parameter of ``machine`` (active or not)."""
    p = parse_parameter(name)
    if p.axis not in machine.axis_names:
        raise ValueError(f"{p.name}: axis {p.axis} is not in {machine.topology.string}")
    component = COMPONENTS[p.component]
    direction = _DIRECTION[component]
    point = reference_point(machine, p.axis)
    stylus = _stylus_point(machine)
    side = machine.topology.side(p.axis)
    if p.kind == "location":
        verb, how = ("turns", "about") if p.is_rotation else ("moves", "along")
        positive = (
            f"{verb} the average line of axis {p.axis}, with what it carries, by +{p.name} "
            f"{how} {direction} ({'right-hand rule, ' if p.is_rotation else ''}machine frame)"
        )
        reference = f"{p.axis} reference point {_fmt(point)} mm at zero readings"
        if p.is_rotation:
            reference = "about the " + reference
    else:
        verb, how = ("turns", "about") if p.is_rotation else ("deviates", "along")
        term = f"·sense_{p.axis}" if p.kind == "reversal" else _basis_term(machine, p)
        positive = (
            f"the tool {verb} by +{p.name}{term} {how} {direction} relative to the workpiece"
            + _position_unit(machine, p)
        )
        if p.kind == "reversal":
            positive += f" (sense_{p.axis} = +1 when {p.axis} arrived moving in +)"
        body = "table" if side == "workpiece" else "spindle side"
        act = "acting about" if p.is_rotation else "measured at"
        reference = (
            f"{act} the {p.axis} reference point, a point of the {body} at {_fmt(point)} mm "
            "at zero readings"
        )
    tool_axes = machine.topology.tool_axes
    if tool_axes and p.axis == tool_axes[-1]:
        reference += f" (the stylus centre is at {_fmt(stylus)} mm)"
    return ParameterConvention(
        name=p.name,
        unit=machine.unit_of(p),
        kind=p.kind,
        axis=p.axis,
        side=side,
        positive=positive,
        reference=reference,
        reference_point_mm=tuple(float(v) + 0.0 for v in point),
    )


def describe_parameters(machine: Machine) -> list[ParameterConvention]:
    """The conventions of every active parameter of ``machine``, in model order."""
    return [describe_parameter(machine, n) for n in machine.parameter_names]


def machine_description(machine: Machine) -> dict:
    """The ``machine-description`` document of ``mtm machine show --json``.

    Axes with their geometry (travel and resolution in mm or degrees), the tool, and every
    active parameter with its unit, sign convention and reference point.
    """
    axes = []
    for a in machine.axis_names:
        g = machine.axes[a]
        linear = a in LINEAR_AXES
        unit = "mm" if linear else "deg"
        travel = None if g.travel is None else [float(from_internal(v, unit)) for v in g.travel]
        resolution = None if g.resolution is None else float(from_internal(g.resolution, unit))
        axes.append(
            {
                "axis": a,
                "type": "linear" if linear else "rotary",
                "branch": machine.topology.side(a),
                "direction": [float(v) for v in g.direction],
                "sign": int(g.sign),
                "travel": travel,
                "resolution": resolution,
                "unit": unit,
                "offset_mm": [float(v) for v in g.offset],
                "reference_point_mm": [float(v) + 0.0 for v in reference_point(machine, a)],
                "basis": g.basis.kind,
            }
        )
    return {
        "kind": "machine-description",
        "version": 1,
        "name": machine.name,
        "topology": machine.topology.string,
        "model": machine.model_name,
        "models": list(machine.spec.error_models) if machine.spec else [],
        "tool_mm": machine.tool.tolist(),
        "stylus_at_zero_mm": [float(v) + 0.0 for v in _stylus_point(machine)],
        "tip_radius_mm": machine.tip_radius,
        "axes": axes,
        "parameters": [c.to_dict() for c in describe_parameters(machine)],
    }
