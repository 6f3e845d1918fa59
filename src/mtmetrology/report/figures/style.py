"""The common look of the report figures: a new constrained-layout figure, axis labels with
their unit, and the palette."""

from __future__ import annotations

from matplotlib.figure import Figure

__all__ = ["BLUE", "GREEN", "GREY", "ORANGE", "RED", "axis_label", "new_figure"]

#: The palette: data, a second series or the GUF law, within limits, outside, reference.
BLUE, ORANGE, GREEN, RED, GREY = "#2a5d8f", "#d9822b", "#3f8f4a", "#b8383b", "#8c959f"


def new_figure(width: float = 6.4, height: float = 3.8) -> Figure:
    """A new figure of ``width`` × ``height`` inches with constrained layout, built without
    :mod:`matplotlib.pyplot` (no global state)."""
    return Figure(figsize=(width, height), layout="constrained")


def axis_label(name: str, unit: str) -> str:
    """``"name (unit)"``, or ``name`` alone when ``unit`` is empty."""
    return f"{name} ({unit})" if unit else name
