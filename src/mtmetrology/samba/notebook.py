"""``_repr_html_`` for the SAMBA result objects (their report fragment in Jupyter).

The renderers of the SAMBA results live in :mod:`mtmetrology.samba.report`, which imports
matplotlib; this mixin loads that module only when a notebook first displays a result, so
that importing :mod:`mtmetrology.samba` stays free of the plotting stack.
"""

from __future__ import annotations

from mtmetrology.display import NotebookRepr

__all__ = ["SambaNotebookRepr"]


class SambaNotebookRepr(NotebookRepr):
    """:class:`~mtmetrology.display.NotebookRepr` that registers the SAMBA renderers."""

    __slots__ = ()
    _renderer_module = "mtmetrology.samba.report"
