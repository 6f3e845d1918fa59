"""Self-contained HTML reports: sections, tables and matplotlib figures as inline SVG.

A report is built block by block and written as one HTML file that needs no network and
no other file (the figures are inline SVG, the style sheet is embedded, there is no
script), so it opens offline in any browser, prints on paper and can be archived with a
calibration certificate::

    from mtmetrology.report import Report, figures

    rep = Report("End gauge, GUM H.1", command="mtm uncertainty run h1.yaml")
    rep.section("Result", "GUF and Monte Carlo agree within 0.5 nm.")
    rep.table(["output", "value", "u"], [["l", 50000838.6, 31.7]], caption="nm")
    rep.figure(figures.budget_bars(["l_s", "d", "θ"], [25.0, 9.7, 16.6], unit="nm"))
    rep.write("report.html")

Result objects render the same tables and figures in Jupyter through
:class:`mtmetrology.display.NotebookRepr` (``_repr_html_``) and the renderer
registry of :mod:`mtmetrology.display`; the renderers of the engines' results are in
:mod:`mtmetrology.report.results`.

``Report`` is loaded on first use (PEP 562), so that the result classes of the lower
layers never load Jinja2 or matplotlib before a result is shown.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from mtmetrology.report import figures
    from mtmetrology.report.document import Report

__all__ = ["Report", "figures"]


def __getattr__(name: str):
    if name == "Report":
        from mtmetrology.report.document import Report

        return Report
    if name == "figures":
        return importlib.import_module("mtmetrology.report.figures")
    raise AttributeError(f"module 'mtmetrology.report' has no attribute {name!r}")
