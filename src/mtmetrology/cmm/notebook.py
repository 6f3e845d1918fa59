"""``_repr_html_`` for the CMM result objects (their report fragment in Jupyter).

The renderers of the CMM results live in :mod:`mtmetrology.cmm.report`, which imports
matplotlib; this mixin loads that module only when a notebook first displays a result, so
that importing :mod:`mtmetrology.cmm` stays free of the plotting stack.
"""

from __future__ import annotations

from mtmetrology.display import NotebookRepr

__all__ = ["CMMNotebookRepr"]


class CMMNotebookRepr(NotebookRepr):
    """:class:`~mtmetrology.display.NotebookRepr` that registers the CMM renderers."""

    __slots__ = ()
    _renderer_module = "mtmetrology.cmm.report"
