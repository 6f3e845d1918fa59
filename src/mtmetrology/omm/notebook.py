"""``_repr_html_`` for the OMM result objects (their report fragment in Jupyter).

The renderers of the OMM results live in :mod:`mtmetrology.omm.report`, which imports
matplotlib; this mixin loads that module only when a notebook first displays a result, so
that importing :mod:`mtmetrology.omm` stays free of the plotting stack.
"""

from __future__ import annotations

from mtmetrology.display import NotebookRepr

__all__ = ["OMMNotebookRepr"]


class OMMNotebookRepr(NotebookRepr):
    """:class:`~mtmetrology.display.NotebookRepr` that registers the OMM renderers."""

    __slots__ = ()
    _renderer_module = "mtmetrology.omm.report"
