"""Machine topology strings (ISO 10791 / the sources' notation).

A topology string lists the machine's bodies from the workpiece ``W`` to the tool
``T`` through the frame (bed, foundation) ``F``: ``WCBXFZYST`` is a five-axis
machine whose table carries X, then B, then C, then the workpiece, and whose
spindle head carries Z, then Y, then the spindle S and the tool.  Letters left of
``F`` move the workpiece, letters right of it move the tool.

Axis letters: ``X Y Z`` linear, ``A B C`` rotary about X, Y, Z, ``S`` the spindle
(rotary about Z, indexed for tool/spindle separation; ISO 230-1 writes it C1).
The variants used in the sources are accepted and normalised: lower-case ``w``/``t``,
``b`` or ``f`` for the bed, and ``(C1)`` for the spindle, so ``wCBXbZY(C1)t`` reads
as ``WCBXFZYST``.

Examples
--------
>>> t = parse_topology("WCBXFZYST")
>>> t.workpiece_axes, t.tool_axes
(('X', 'B', 'C'), ('Z', 'Y', 'S'))
"""

from __future__ import annotations

from dataclasses import dataclass

from mtmetrology.errors import InputError

__all__ = ["AXIS_LETTERS", "LINEAR_AXES", "ROTARY_AXES", "Topology", "TopologyError"]

LINEAR_AXES = ("X", "Y", "Z")
ROTARY_AXES = ("A", "B", "C", "S")
AXIS_LETTERS = LINEAR_AXES + ROTARY_AXES
# Canonical order of axis readings in arrays: linear axes, then rotary, then spindle.
_READING_ORDER = "XYZABCS"


class TopologyError(InputError):
    """A topology string that does not describe a serial machine."""


@dataclass(frozen=True)
class Topology:
    """A parsed topology.

    Attributes
    ----------
    string : str
        The normalised topology string, e.g. ``"WCBXFZYST"``.
    workpiece_axes : tuple of str
        Axes of the workpiece branch in order from the frame outwards (F -> W):
        ``("X", "B", "C")`` for ``WCBXFZYST``.
    tool_axes : tuple of str
        Axes of the tool branch from the frame outwards (F -> T).
    """

    string: str
    workpiece_axes: tuple[str, ...]
    tool_axes: tuple[str, ...]

    @property
    def axes(self) -> tuple[str, ...]:
        """All axes in the canonical reading order (X, Y, Z, A, B, C, S)."""
        present = set(self.workpiece_axes) | set(self.tool_axes)
        return tuple(a for a in _READING_ORDER if a in present)

    def side(self, axis: str) -> str:
        """``"workpiece"`` or ``"tool"``: the branch that carries ``axis``."""
        if axis in self.workpiece_axes:
            return "workpiece"
        if axis in self.tool_axes:
            return "tool"
        raise TopologyError(f"axis {axis!r} is not in topology {self.string!r}")

    def parent(self, axis: str) -> str:
        """The body that carries ``axis`` (``"F"`` for the first axis of a branch)."""
        branch = self.workpiece_axes if self.side(axis) == "workpiece" else self.tool_axes
        i = branch.index(axis)
        return "F" if i == 0 else branch[i - 1]


def _normalise(text: str) -> str:
    s = text.strip().replace("(C1)", "S").replace("(c1)", "S")
    out = []
    for ch in s:
        if ch in "wW":
            out.append("W")
        elif ch in "tT":
            out.append("T")
        elif ch in "bfF":
            out.append("F")
        else:
            out.append(ch)
    return "".join(out)


def parse_topology(text: str) -> Topology:
    """Parse a topology string read from workpiece to tool through the frame.

    Parameters
    ----------
    text : str
        E.g. ``"WCBXFZYST"``, ``"WXFYZT"``, ``"WFYXZT"``, ``"wCBXbZY(C1)t"``.

    Returns
    -------
    Topology

    Raises
    ------
    TopologyError
        Unknown letters, repeated axes, or a missing/misplaced W, F or T.
    """
    if not isinstance(text, str) or not text.strip():
        raise TopologyError("topology must be a non-empty string such as 'WCBXFZYST'")
    s = _normalise(text)
    unknown = sorted({c for c in s if c not in (*AXIS_LETTERS, "W", "F", "T")})
    if unknown:
        raise TopologyError(
            f"topology {text!r}: unknown letter(s) {', '.join(map(repr, unknown))}; "
            "use W (workpiece), F (frame), T (tool), X Y Z (linear), A B C (rotary), S (spindle)"
        )
    for mark, what in (("W", "workpiece"), ("F", "frame"), ("T", "tool")):
        n = s.count(mark)
        if n != 1:
            raise TopologyError(f"topology {text!r}: needs exactly one {mark} ({what}), found {n}")
    if not (s[0] == "W" and s[-1] == "T"):
        raise TopologyError(
            f"topology {text!r}: must start with W (workpiece) and end with T (tool), "
            "reading from workpiece to tool through the frame F"
        )
    body = s[1:-1]
    repeated = sorted({c for c in body if c != "F" and body.count(c) > 1})
    if repeated:
        raise TopologyError(f"topology {text!r}: repeated axis {', '.join(repeated)}")
    left, _, right = body.partition("F")
    return Topology(
        string=s,
        workpiece_axes=tuple(reversed(left)),
        tool_axes=tuple(right),
    )
