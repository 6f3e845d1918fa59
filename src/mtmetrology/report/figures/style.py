"""The common look of the report figures: a new constrained-layout figure, axis labels with
their unit, tick labels without offset, legends outside the data, and the palette."""

from __future__ import annotations

from matplotlib.figure import Figure
from matplotlib.ticker import ScalarFormatter

__all__ = [
    "BLUE",
    "GREEN",
    "GREY",
    "ORANGE",
    "RED",
    "axis_label",
    "legend_below",
    "new_figure",
    "plain_ticks",
]

#: The palette: data, a second series or the GUF law, within limits, outside, reference.
BLUE, ORANGE, GREEN, RED, GREY = "#2a5d8f", "#d9822b", "#3f8f4a", "#b8383b", "#8c959f"


def new_figure(width: float = 6.4, height: float = 3.8) -> Figure:
    """A new figure of ``width`` × ``height`` inches with constrained layout, built without
    :mod:`matplotlib.pyplot` (no global state)."""
    return Figure(figsize=(width, height), layout="constrained")


def axis_label(name: str, unit: str) -> str:
    """``"name (unit)"``, or ``name`` alone when ``unit`` is empty."""
    return f"{name} ({unit})" if unit else name


def plain_ticks(fig: Figure) -> Figure:
    """Every linear axis of ``fig`` labelled with its plain values: no offset ("+2.828e2")
    and no multiplier ("1e-5") in a corner, which a reader misses or misreads. Figures of
    deviations plot them from their nominal in µm, µrad, µm/m, so the plain values are short.
    Log and categorical axes are left alone. Idempotent; returns ``fig``.

    Examples
    --------
    >>> fig = new_figure()
    >>> ax = fig.add_subplot()
    >>> _ = ax.plot([282.84261, 282.84263], [0, 1])
    >>> fig.draw_without_rendering()
    >>> ax.xaxis.get_major_formatter().get_offset() != ""
    True
    >>> _ = plain_ticks(fig)
    >>> fig.draw_without_rendering()
    >>> ax.xaxis.get_major_formatter().get_offset()
    ''
    """
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            formatter = axis.get_major_formatter()
            if isinstance(formatter, ScalarFormatter):
                formatter.set_useOffset(False)
                formatter.set_scientific(False)
    return fig


def legend_below(fig: Figure, ax, *, fontsize: float = 8) -> None:
    """The legend of ``ax``'s labelled artists under the figure, outside every axes, so that
    it covers no data (constrained layout makes room for it); nothing without labels."""
    handles, labels = ax.get_legend_handles_labels()
    if handles:
        fig.legend(
            handles,
            labels,
            loc="outside lower center",
            ncol=min(len(labels), 4),
            fontsize=fontsize,
            frameon=False,
        )
