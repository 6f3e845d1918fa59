"""Result objects that show themselves in Jupyter with the tables and figures of a report.

A result class gains ``_repr_html_`` by inheriting :class:`NotebookRepr`; what is shown
is what :func:`mtmetrology.report.results.add_result` puts in a report for that class, so
a notebook and an HTML report never disagree::

    @dataclass(frozen=True)
    class CalibrationResult(NotebookRepr):
        ...

and, in the application's module (or in :mod:`mtmetrology.report.results`)::

    @renders("mtmetrology.samba.calibration.CalibrationResult")
    def _calibration(rep, result, **context): ...

This module imports nothing at load time, so that the lower layers (uncertainty,
identification, fitting, kinematics) can inherit the mixin without importing Jinja2 or
matplotlib; the renderer is loaded when a notebook first displays a result.
"""

from __future__ import annotations

import importlib

__all__ = ["NotebookRepr"]


class NotebookRepr:
    """Mixin: ``_repr_html_`` renders the object as its report fragment (scoped style).

    A subclass whose renderers live in a module of their own (one that imports
    matplotlib) names it in ``_renderer_module``; it is imported on the first display.
    """

    __slots__ = ()
    #: Module registering the class's renderers, imported lazily (None: already known).
    _renderer_module: str | None = None

    def _repr_html_(self) -> str:
        from mtmetrology.report.results import result_report

        if self._renderer_module is not None:
            importlib.import_module(self._renderer_module)

        return result_report(self).fragment()
