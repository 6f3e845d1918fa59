"""The ISO 230-2 figure and HTML report (tables from the result, nothing computed here).

The figure is the one the standard shows for a linear axis: the mean unidirectional
positional deviations x̄_i↑ and x̄_i↓ against the target position, each with its band
x̄_i ± 2 s_i, the reversal between them, and the axis parameters in the caption.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from mtmetrology.formatting import format_share, format_uncertainty, format_value
from mtmetrology.positioning.workflow import PositioningResult
from mtmetrology.report import Report
from mtmetrology.report.figures.style import (
    BLUE,
    ORANGE,
    axis_label,
    legend_below,
    new_figure,
    plain_ticks,
)
from mtmetrology.report.results import add_result, renders
from mtmetrology.units import from_internal

__all__ = ["deviation_figure", "positioning_report"]


def deviation_figure(result) -> Figure:
    """x̄_i↑ and x̄_i↓ (µm) against the target position (mm) with their ±2 s_i bands.

    Parameters
    ----------
    result : PositioningResult

    Returns
    -------
    Figure
    """
    p = result.targets
    x = from_internal(result.deviations, "µm")
    fig = new_figure(6.4, 3.8)
    ax = fig.add_subplot()
    for d, (name, colour) in enumerate((("↑ positive approach", BLUE), ("↓ negative", ORANGE))):
        mean = x[:, :, d].mean(axis=1)
        s = x[:, :, d].std(axis=1, ddof=1)
        ax.plot(p, mean, "o-", color=colour, ms=3, lw=1.2, label=f"x̄ {name}")
        ax.fill_between(p, mean - 2 * s, mean + 2 * s, color=colour, alpha=0.2, lw=0)
        ax.plot(np.repeat(p, x.shape[1]), x[:, :, d].ravel(), ".", color=colour, ms=2, alpha=0.5)
    ax.axhline(0.0, color="black", lw=0.6)
    ax.set_xlabel(axis_label(f"target position {result.axis}", "mm"))
    ax.set_ylabel(axis_label("positional deviation", "µm"))
    ax.set_title(f"{result.axis} axis, bands x̄ ± 2s")
    legend_below(fig, ax)
    return plain_ticks(fig)


def positioning_report(result, command: str, inputs: list[Path]) -> Report:
    """Report of a :class:`~mtmetrology.positioning.workflow.PositioningResult`."""
    report = Report(
        f"ISO 230-2 positioning of axis {result.axis}",
        command=command,
        provenance={"inputs": list(inputs)},
    )
    add_result(report, result)
    return report


@renders(PositioningResult, "ISO 230-2 positioning")
def _render(rep, result, **_context) -> None:
    """The sections of a result: summary, parameters with U, figure, pitch table, budget."""
    rep.section("Result", result.summary())
    u = result.budget.parameter_u()
    k = result.budget.k
    rows = []
    for key, value in result.parameters.items():
        big_u = None if key not in u else k * u[key]
        rows.append([key, format_value(float(value), big_u), format_uncertainty(big_u), "µm"])
    rep.table(["parameter", "value", f"U (k = {k:g})", "unit"], rows, caption="Parameters")
    rep.figure(deviation_figure(result), caption="Deviation against position per direction")
    pitch = result.pitch_table()
    rep.table(
        ["position (mm)", "x̄_i (µm)", "B_i (µm)", "u(x̄_i) (µm)"],
        [
            [pos, format_value(v, w), format_value(b, w), format_uncertainty(w)]
            for pos, v, b, w in zip(
                pitch["position_mm"],
                pitch["mean_um"],
                pitch["reversal_um"],
                pitch["u_mean_um"],
                strict=True,
            )
        ],
        caption="Pitch-compensation table (the control applies −x̄_i, ∓B_i/2 per direction)",
    )
    rep.table(
        ["input", "u", "unit", "contribution (µm)", "share"],
        [
            [
                r["input"],
                format_uncertainty(r["u"]),
                r["unit"],
                format_uncertainty(r["contribution_um"]),
                format_share(r["share"]),
            ]
            for r in result.budget.rows
        ],
        caption="ISO/TR 230-9 budget at the longest distance from the datum",
    )
