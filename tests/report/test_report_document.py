"""Tests for mtmetrology.report.document: a self-contained, escaped, atomic HTML page."""

from __future__ import annotations

import hashlib
import re
from html.parser import HTMLParser

import numpy as np
import pytest
import scipy
from matplotlib.figure import Figure

from mtmetrology.report import Report, figures
from mtmetrology.report.format import format_cell, format_value


class _Links(HTMLParser):
    """Every URL-bearing attribute and every element name of a page."""

    def __init__(self):
        super().__init__()
        self.urls: list[str] = []
        self.tags: list[str] = []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        self.urls += [v for k, v in attrs if k in ("src", "href", "xlink:href", "action") and v]


def _parse(page: str) -> _Links:
    parser = _Links()
    parser.feed(page)
    return parser


def _line_figure() -> Figure:
    fig = Figure()
    fig.add_subplot().plot([0, 1, 2], [1, 3, 2])
    return fig


def test_page_needs_no_network_no_file_and_no_script():
    rep = Report("Self-contained")
    rep.section("Figures").figure(_line_figure()).figure(figures.convergence([1.0, 2.0, 2.5]))
    page = rep.html()
    links = _parse(page)
    assert "script" not in links.tags and "link" in links.tags  # only the empty favicon
    assert all(u.startswith(("#", "data:")) for u in links.urls), links.urls
    assert "@import" not in page and "url(http" not in page


def test_text_headings_and_cells_are_escaped():
    rep = Report("<b>title</b>")
    rep.section("<script>alert(1)</script>", "x < y & z").table(["<th>"], [["<td>"]])
    page = rep.html()
    assert "<script>alert" not in page and "&lt;script&gt;" in page
    assert "x &lt; y &amp; z" in page and "&lt;td&gt;" in page and "<b>title" not in page


def test_each_figure_is_one_inline_svg_with_ids_unique_across_the_page():
    rep = Report("Two identical figures")
    rep.figure(figures.budget_bars(["a", "b"], [1.0, 2.0])).figure(
        figures.budget_bars(["a", "b"], [1.0, 2.0])
    )
    page = rep.html()
    assert page.count("<svg") == 2 and page.count('class="mtm-figure"') == 2
    ids = re.findall(r'\bid="([^"]+)"', page)
    assert len(ids) == len(set(ids))
    # every url(#...) / href="#..." points to an id of the page
    refs = re.findall(r'(?:url\(#|href="#)([^)"]+)', page)
    assert refs and set(refs) <= set(ids)
    assert "<?xml" not in page and "<!DOCTYPE svg" not in page


def test_figure_is_closed_in_pyplot():
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib import pyplot as plt

    fig = plt.figure()
    fig.add_subplot().plot([0, 1])
    Report("closing").figure(fig)
    assert not plt.fignum_exists(fig.number)


def test_numeric_columns_are_right_aligned_and_mixed_ones_are_not():
    rep = Report("alignment").table(["name", "value", "mixed"], [["a", 1.5, 2.0], ["b", 2, "x"]])
    page = rep.html()
    header = re.search(r"<thead><tr>(.*?)</tr></thead>", page).group(1)
    assert re.findall(r'<th scope="col"( class="num")?>', header) == ["", ' class="num"', ""]


def test_table_row_of_wrong_length_is_refused():
    with pytest.raises(ValueError, match="row 1"):
        Report("t").table(["a", "b"], [[1, 2], [3]])


def test_empty_title_is_refused():
    with pytest.raises(ValueError, match="non-empty title"):
        Report("  ")


def test_provenance_records_command_inputs_versions_and_date(tmp_path):
    data = tmp_path / "points.csv"
    data.write_text("x,y,z\n0,0,0\n")
    rep = Report("p", command="mtm fit sphere points.csv", provenance={"inputs": [data], "seed": 7})
    prov = rep.provenance
    assert prov["command"] == "mtm fit sphere points.csv" and prov["seed"] == "7"
    assert hashlib.sha256(data.read_bytes()).hexdigest() in prov["inputs"]
    assert prov["numpy"] == np.__version__ and prov["scipy"] == scipy.__version__
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", prov["date"])
    assert "sha256" in rep.html()


def test_write_is_atomic_and_leaves_no_temporary_file(tmp_path):
    rep = Report("written").section("s", "text")
    (tmp_path / "sub").mkdir()
    target = rep.write(tmp_path / "sub" / "r.html")
    assert target.read_text(encoding="utf-8") == rep.html()
    assert [p.name for p in target.parent.iterdir()] == ["r.html"]


def test_failed_write_keeps_the_previous_report(tmp_path, monkeypatch):
    target = tmp_path / "r.html"
    target.write_text("previous")
    rep = Report("new")
    monkeypatch.setattr(Report, "html", lambda self: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        rep.write(target)
    assert target.read_text() == "previous" and len(list(tmp_path.iterdir())) == 1


def test_fragment_scopes_its_style_to_the_report():
    frag = Report("f").section("s", "t").fragment()
    assert frag.startswith('<div class="mtm-report">') and "<html" not in frag
    css = re.search(r"<style>(.*?)</style>", frag, re.S).group(1)
    selectors = [s.strip() for s in re.findall(r"([^{}]+)\{", css) if not s.strip().startswith("@")]
    assert selectors and all(s.startswith(".mtm-report") for s in selectors)


def test_values_are_rounded_to_their_uncertainty_gum_7_2_6():
    """GUM H.1: l = 50 000 838 nm with u = 32 nm (JCGM 100:2008, H.1.6)."""
    assert format_value(50_000_838.62, 31.7) == "50000839"
    assert format_value(1.23456, 0.0123) == "1.235"
    assert format_cell(50_000_838.6) == "50000838.6"
