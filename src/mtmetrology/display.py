"""How a result object is shown: the notebook mixin and the renderer registry.

A leaf module (it imports nothing of the package), so that every layer can use it: the
result classes of the engines and of the applications inherit :class:`NotebookRepr`, and
the layers above register, for each result class, the one function that shows it::

    # in the engine or the application (the result class)
    @dataclass(frozen=True)
    class CalibrationResult(NotebookRepr):
        _renderer_module = "mtmetrology.samba.report"

    # in mtmetrology/samba/report.py (above: it imports the class and the report layer)
    @register(CalibrationResult, "SAMBA calibration")
    def _calibration(rep, result, **context): ...

A renderer ``func(rep, result, **context)`` appends sections to a
:class:`mtmetrology.report.Report`. It is looked up by class through the method
resolution order, so a subclass is shown as its nearest registered base. The same
renderer makes the notebook display (``_repr_html_``) and the sections an HTML report
adds with :func:`mtmetrology.report.results.add_result`, so the two never disagree.

The module that registers a class's renderer is named as a string in the class's
``_renderer_module`` (by default :mod:`mtmetrology.report.results`, which holds the
engines' renderers) and imported on the first display: importing an engine loads
neither Jinja2 nor matplotlib, and no engine imports the report layer. That module also
installs, through :func:`set_html_builder`, the function that turns a renderer and a
result into an HTML fragment (the report layer does it when loaded).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any, NamedTuple

__all__ = ["NotebookRepr", "Renderer", "html", "register", "renderer_for", "set_html_builder"]


class Renderer(NamedTuple):
    """A registered renderer: the function and the title of a report of that result alone."""

    func: Callable[..., None]
    title: str


_RENDERERS: dict[type, Renderer] = {}
_HTML_BUILDER: Callable[[Renderer, Any], str] | None = None


def register(cls: type, title: str | None = None) -> Callable:
    """Register ``func(rep, result, **context)`` as the renderer of ``cls`` (decorator).

    Parameters
    ----------
    cls : type
        The result class (the class object, not its name).
    title : str, optional
        The title of a report made of that result alone (default: the class name).

    Raises
    ------
    TypeError
        If ``cls`` is not a class.
    """
    if not isinstance(cls, type):
        raise TypeError(f"renderers are registered by class, not by {type(cls).__name__}")

    def decorate(func: Callable[..., None]) -> Callable[..., None]:
        _RENDERERS[cls] = Renderer(func, title or cls.__name__)
        return func

    return decorate


def _find(cls: type) -> Renderer | None:
    for base in cls.__mro__:
        if base in _RENDERERS:
            return _RENDERERS[base]
    return None


def renderer_for(result: object) -> Renderer:
    """The renderer of ``result``'s class or of its nearest registered base.

    The module named by the class's ``_renderer_module`` (and by its bases') is imported
    first when no renderer is registered yet.

    Raises
    ------
    TypeError
        If no renderer is registered for the class or any of its bases.
    """
    cls = type(result)
    found = _find(cls)
    if found is None:
        for base in cls.__mro__:
            module = base.__dict__.get("_renderer_module")
            if module:
                importlib.import_module(module)
        found = _find(cls)
    if found is None:
        raise TypeError(f"no renderer registered for {cls.__module__}.{cls.__qualname__}")
    return found


def set_html_builder(builder: Callable[[Renderer, Any], str]) -> None:
    """Install ``builder(renderer, result) -> str``, the HTML fragment of a result.

    Called by the report layer when it is imported; :func:`html` uses it.
    """
    global _HTML_BUILDER
    _HTML_BUILDER = builder


def html(result: object) -> str:
    """The HTML fragment (scoped style) that shows ``result``: what Jupyter displays.

    Raises
    ------
    TypeError
        If no renderer is registered for the result's class.
    RuntimeError
        If the renderer's module installed no HTML builder.
    """
    renderer = renderer_for(result)
    if _HTML_BUILDER is None:
        raise RuntimeError("no HTML builder installed (the report layer was not imported)")
    return _HTML_BUILDER(renderer, result)


class NotebookRepr:
    """Mixin: ``_repr_html_`` shows the object as its report fragment (scoped style).

    ``_renderer_module`` names the module that registers the class's renderer; it is
    imported on the first display.
    """

    __slots__ = ()
    #: Module registering the class's renderer, imported lazily. The default is the report
    #: layer's module of the engines' renderers; an application names its own.
    _renderer_module: str | None = "mtmetrology.report.results"

    def _repr_html_(self) -> str:
        return html(self)
