"""The figures of mtmetrology reports, as matplotlib :class:`~matplotlib.figure.Figure`.

Every function returns a new figure built without :mod:`matplotlib.pyplot` (no global
state, no display needed: the figures render with the Agg/SVG canvases on a headless
machine) and takes quantities in the units it prints: callers convert with
:mod:`mtmetrology.units` before plotting (µm, µrad, µm/m, mm, degrees). Pass the figure
to :meth:`mtmetrology.report.Report.figure`, or show it in a notebook.

The figures are grouped by what they show: :mod:`.uncertainty` (a result and its
uncertainty), :mod:`.machines` (fits, error maps and identifications of machines and
artefacts) and :mod:`.monitoring` (a machine over time); :mod:`.style` holds their
common look.

References
----------
JCGM 100:2008, *Evaluation of measurement data — Guide to the expression of uncertainty
in measurement* (budgets, 7.2.6 rounding). JCGM 101:2008, *Propagation of distributions
using a Monte Carlo method* (histogram against the GUF PDF, 9). JCGM 102:2011,
*Extension to any number of output quantities* (coverage regions, 7.7). ISO
14253-1:2017, *Decision rules for verifying conformity or nonconformity with
specifications* (conformance and nonconformance zones).
"""

from mtmetrology.report.figures.machines import (
    circular_trace,
    convergence,
    error_map,
    length_errors,
    point_deviations,
    residual_profile,
    residual_vectors,
    singular_values,
)
from mtmetrology.report.figures.monitoring import (
    control_chart,
    hysteresis_bars,
    window_repeatability,
)
from mtmetrology.report.figures.uncertainty import (
    budget_bars,
    conformity_zones,
    correlation_heatmap,
    coverage_ellipses,
    histogram_vs_normal,
    parameter_table_columns,
    parameter_table_rows,
)

__all__ = [
    "budget_bars",
    "circular_trace",
    "conformity_zones",
    "control_chart",
    "convergence",
    "correlation_heatmap",
    "coverage_ellipses",
    "error_map",
    "histogram_vs_normal",
    "hysteresis_bars",
    "length_errors",
    "parameter_table_columns",
    "parameter_table_rows",
    "point_deviations",
    "residual_profile",
    "residual_vectors",
    "singular_values",
    "window_repeatability",
]
