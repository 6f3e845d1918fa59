"""The :class:`Report`: sections of text, tables and figures, rendered to one HTML file.

Figures are matplotlib figures saved as SVG and inlined in the page. SVG keeps the
report one file of modest size (a figure is 20–80 kB of text, where a JavaScript
plotting library embeds ~3 MB of script in every report), needs no network and no
script (nothing can fail to load or be blocked), scales without blur on screen and
paper, and its text stays searchable. The page has an embedded print style sheet.
"""

from __future__ import annotations

import hashlib
import io
import json
import numbers
import platform
import re
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from importlib import resources
from pathlib import Path

from mtmetrology import __version__
from mtmetrology.formatting import format_cell
from mtmetrology.io.files import atomic_write

__all__ = ["Report", "figure_svg", "input_record"]

_TEMPLATE = "report.html.j2"


@dataclass(frozen=True)
class _Text:
    text: str
    kind: str = "text"


@dataclass(frozen=True)
class _Table:
    columns: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]
    numeric: tuple[bool, ...]
    caption: str | None
    kind: str = "table"


@dataclass(frozen=True)
class _Figure:
    svg: str
    caption: str | None
    number: int
    kind: str = "figure"


@dataclass
class _Section:
    heading: str | None
    anchor: str
    blocks: list = field(default_factory=list)


def input_record(path: str | Path) -> str:
    """``path (size bytes, sha256 …)`` of an input file, to identify it in a provenance.

    A file that does not exist (a preset name, a directory) is recorded by name only.
    """
    p = Path(path)
    if not p.is_file():
        return str(path)
    digest = hashlib.sha256(p.read_bytes()).hexdigest()
    return f"{path} ({p.stat().st_size} bytes, sha256 {digest})"


def _versions() -> dict[str, str]:
    import numpy
    import scipy

    out = {
        "mtmetrology": __version__,
        "python": platform.python_version(),
        "numpy": numpy.__version__,
        "scipy": scipy.__version__,
    }
    if "matplotlib" in sys.modules:
        out["matplotlib"] = sys.modules["matplotlib"].__version__
    return out


def _provenance_text(value: object) -> str:
    if isinstance(value, str):
        return value
    if isinstance(value, Mapping):
        return json.dumps(value, ensure_ascii=False, default=str)
    if isinstance(value, Sequence):
        return "; ".join(_provenance_text(v) for v in value)
    return format_cell(value)


_ID = re.compile(r'\bid="([^"]+)"')


def figure_svg(fig, prefix: str = "f") -> str:
    """The ``<svg>`` element of a matplotlib figure, ready to inline in HTML.

    The XML prolog is dropped and every ``id`` (clip paths, markers) is prefixed so that
    several figures in one page cannot refer to each other's definitions. Text stays
    text (``svg.fonttype: none``): smaller files, searchable in the browser.
    """
    import matplotlib

    from mtmetrology.report.figures.style import plain_ticks

    plain_ticks(fig)  # figures built outside report.figures too: no offset on any axis
    buffer = io.StringIO()
    with matplotlib.rc_context({"svg.fonttype": "none", "svg.hashsalt": "mtmetrology"}):
        fig.savefig(buffer, format="svg", bbox_inches="tight", dpi=150, metadata={"Date": None})
    text = buffer.getvalue()
    text = text[text.index("<svg") :]
    for name in set(_ID.findall(text)):
        new = f"{prefix}-{name}"
        text = text.replace(f'id="{name}"', f'id="{new}"')
        text = text.replace(f"#{name})", f"#{new})").replace(f'"#{name}"', f'"#{new}"')
    return text


def figure_title(fig) -> str:
    """The title of a figure: its ``suptitle``, else the first axes title; "" if none."""
    suptitle = getattr(fig, "_suptitle", None)
    if suptitle is not None and suptitle.get_text().strip():
        return suptitle.get_text().strip()
    for ax in fig.axes:
        if ax.get_title().strip():
            return ax.get_title().strip()
    return ""


def _close(fig) -> None:
    pyplot = sys.modules.get("matplotlib.pyplot")
    if pyplot is not None:
        pyplot.close(fig)


class Report:
    """An HTML report: a title, sections of text, tables and figures, a provenance.

    Parameters
    ----------
    title : str
        The report's title (also the HTML ``<title>``).
    command : str, optional
        The command line that produced the results, shown in the provenance so that a
        reader can rerun it.
    provenance : mapping, optional
        What the results depend on: ``inputs`` (file paths: recorded with size and
        SHA-256), ``seed``, settings ... Values are shown as text. The versions of
        mtmetrology, Python, numpy, scipy (and matplotlib when used) and the date (UTC)
        are added.

    Examples
    --------
    >>> rep = Report("Demo", command="mtm demo")
    >>> rep.section("Numbers", "a < b & c").table(["x", "y"], [[1, 0.25]]) is rep
    True
    >>> page = rep.html()
    >>> "a &lt; b &amp; c" in page and "<script" not in page
    True
    """

    def __init__(
        self,
        title: str,
        *,
        command: str | None = None,
        provenance: Mapping[str, object] | None = None,
    ) -> None:
        if not isinstance(title, str) or not title.strip():
            raise ValueError("a report needs a non-empty title")
        self.title = title
        self.command = command
        self._user_provenance = dict(provenance or {})
        self._created = datetime.now(UTC).replace(microsecond=0)
        self._sections: list[_Section] = []
        self._figures = 0

    # -- building ------------------------------------------------------------------------
    def section(self, heading: str, text: str | None = None) -> Report:
        """Start a section; ``text`` (plain text, escaped; blank lines part paragraphs)."""
        self._sections.append(_Section(heading, f"s{len(self._sections) + 1}"))
        if text:
            self.text(text)
        return self

    def text(self, text: str) -> Report:
        """A paragraph of plain text (escaped) in the current section."""
        for paragraph in str(text).split("\n\n"):
            if paragraph.strip():
                self._current().blocks.append(_Text(paragraph.strip()))
        return self

    def table(
        self,
        columns: Sequence[str],
        rows: Sequence[Sequence[object]],
        *,
        caption: str | None = None,
    ) -> Report:
        """A table; cells are strings (kept) or numbers (formatted, right-aligned).

        Raises
        ------
        ValueError
            If a row does not have one cell per column.
        """
        columns = tuple(str(c) for c in columns)
        cells, numeric = [], [True] * len(columns)
        for i, row in enumerate(rows):
            row = tuple(row)
            if len(row) != len(columns):
                raise ValueError(f"table row {i} has {len(row)} cells for {len(columns)} columns")
            for j, v in enumerate(row):
                if not (v is None or (isinstance(v, numbers.Real) and not isinstance(v, bool))):
                    numeric[j] = False
            cells.append(tuple(format_cell(v) for v in row))
        if not cells:
            numeric = [False] * len(columns)
        self._current().blocks.append(_Table(columns, tuple(cells), tuple(numeric), caption))
        return self

    def figure(self, fig, *, caption: str | None = None) -> Report:
        """A matplotlib figure, inlined as SVG; the figure is closed afterwards.

        Every figure is captioned ("Figure 4." alone tells nothing): without ``caption``,
        the figure's own title (its ``suptitle``, else the first axes title) is the
        caption. The browser tests (tests/report/test_report_browser.py) fail a report
        figure that has neither.
        """
        caption = caption or figure_title(fig)
        self._figures += 1
        try:
            svg = figure_svg(fig, prefix=f"fig{self._figures}")
        finally:
            _close(fig)
        self._current().blocks.append(_Figure(svg, caption, self._figures))
        return self

    def _current(self) -> _Section:
        if not self._sections:
            self._sections.append(_Section(None, "s0"))
        return self._sections[-1]

    # -- output --------------------------------------------------------------------------
    @property
    def provenance(self) -> dict[str, str]:
        """The provenance as printed: command, user entries, versions, date."""
        out: dict[str, str] = {}
        if self.command:
            out["command"] = self.command
        for key, value in self._user_provenance.items():
            if key == "inputs":
                items = [value] if isinstance(value, str | Path) else list(value)  # type: ignore[arg-type]
                out[key] = "; ".join(input_record(p) for p in items)
            else:
                out[str(key)] = _provenance_text(value)
        out.update(_versions())
        out["platform"] = platform.platform()
        out["date"] = self._created.isoformat().replace("+00:00", "Z")
        return out

    def _render(self, *, standalone: bool) -> str:
        import jinja2

        source = resources.files("mtmetrology.report").joinpath("templates", _TEMPLATE)
        env = jinja2.Environment(autoescape=True, trim_blocks=True, lstrip_blocks=True)
        env.filters["safe_svg"] = jinja2.utils.markupsafe.Markup
        template = env.from_string(source.read_text(encoding="utf-8"))
        return template.render(
            title=self.title,
            sections=self._sections,
            provenance=self.provenance,
            standalone=standalone,
            n_figures=self._figures,
        )

    def html(self) -> str:
        """The complete, self-contained HTML page (no script, no external resource)."""
        return self._render(standalone=True)

    def fragment(self) -> str:
        """The report as an HTML fragment with a scoped style (Jupyter ``_repr_html_``)."""
        return self._render(standalone=False)

    def write(self, path: str | Path) -> Path:
        """Write the page atomically (nothing is left behind if writing fails)."""
        path = Path(path)
        page = self.html()
        with atomic_write(path) as fh:
            fh.write(page)
        return path

    def __len__(self) -> int:
        """Number of blocks (texts, tables, figures)."""
        return sum(len(s.blocks) for s in self._sections)

    def __repr__(self) -> str:
        return f"Report({self.title!r}, sections={len(self._sections)}, figures={self._figures})"
