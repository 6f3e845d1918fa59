"""Reports checked in a real browser (headless Chromium over the DevTools protocol).

Each page must load without any request other than its own file (and ``data:`` URIs),
without console errors or uncaught exceptions; every figure must be present, sized,
hold drawn elements and put ink on the screen, have a caption, keep every text and drawn
element inside its SVG viewport and every marker inside its axes, and show no offset or
multiplier on an axis ("+2.828e2", "1e-5"); the page must print to PDF. A full-page
screenshot of each is kept under the artefacts folder.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from chromium import decode_png, ink_fraction

from mtmetrology.report import Report, figures

#: Figures each command's report holds (see test_report_cli.py).
COMMAND_FIGURES = {
    "uncertainty": 2,
    "fit": 2,
    "identifiability": 1,
    "predict": 1,
    # correlation, singular values, one residual map per plate position (4), uncertainty map
    "ballplate": 7,
    "ballplate-budget": 1,
    "gp-fit": 1,
    # correlation, singular values, residual vectors, one MC histogram per parameter (13)
    "samba-calibrate": 16,
    "samba-verify-length": 1,  # errors per pair before/after compensation
    "design": 2,  # DETMAX convergence of step 1 (balls) and step 2 (indexations)
}


#: An axis offset or multiplier as matplotlib writes it: "+2.828e2", "−5e7", "1e−5", "×10⁻⁵".
OFFSET_TEXT = re.compile(r"^([+−-]\d[\d.]*e[+−-]?\d+|1e[+−-]?\d+|×10.*)$")


def figure_problems(fig: dict) -> list[str]:
    """What the browser found wrong with one figure of a page (empty when nothing)."""
    problems = [f"outside the figure: {e}" for e in fig["outside"]]
    problems += [f"marker cut by its axes: {e}" for e in fig["clipped"]]
    problems += [f"axis offset text {t!r}" for t in fig["texts"] if OFFSET_TEXT.match(t)]
    if not re.fullmatch(r"Figure \d+\. \S.*", fig["caption"], flags=re.DOTALL):
        problems.append(f"caption {fig['caption']!r}")
    return problems


def check_page(browser, page, expected_figures: int, artefacts, name: str) -> None:
    load = browser.load(page)
    foreign = [u for u in load.requests if u != load.url and not u.startswith("data:")]
    assert foreign == [], f"{name}: the page requested {foreign}"
    assert load.console_errors == [], f"{name}: console errors {load.console_errors}"
    assert len(load.figures) == expected_figures, name
    image = decode_png(browser.screenshot(artefacts / f"{name}.png"))
    for fig in load.figures:
        assert fig["width"] > 100 and fig["height"] > 60, (name, fig)
        assert fig["drawn"] > 5, (name, fig)
        assert ink_fraction(image, fig) > 0.01, (name, fig)  # not a blank box
        assert figure_problems(fig) == [], (name, fig["number"], figure_problems(fig))
    pdf = browser.print_pdf()
    (artefacts / f"{name}.pdf").write_bytes(pdf)
    assert pdf.startswith(b"%PDF") and len(pdf) > 10_000


def test_every_figure_kind_renders(browser, artefacts, tmp_path):
    rng = np.random.default_rng(11)
    cov = np.array([[1.0, 0.6, 0.0], [0.6, 2.0, -0.4], [0.0, -0.4, 0.5]])
    samples = rng.multivariate_normal(np.zeros(3), cov, 1000)
    grid_x, grid_y = np.linspace(-200, 200, 21), np.linspace(-150, 150, 16)
    points = rng.uniform(-150, 150, (8, 3))
    rep = Report("Every figure", command="pytest", provenance={"seed": 11})
    rep.section("Uncertainty").table(
        figures.parameter_table_columns(),
        figures.parameter_table_rows(
            {"parameters": [{"name": "E_X0C", "value": -104.59, "unit": "µm", "u": 0.73}]}
        ),
    )
    rep.figure(
        figures.correlation_heatmap(
            ["a", "b", "c"], cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
        )
    )
    rep.figure(figures.histogram_vs_normal(samples[:, 0], 0.0, 1.0, "a", "µm", dof=30))
    rep.figure(figures.coverage_ellipses(["a", "b", "c"], np.zeros(3), cov, samples=samples))
    rep.figure(figures.budget_bars(["l_s", "d", "θ"], [0.61, 0.09, 0.30]))
    rep.figure(figures.conformity_zones(10.008, 0.003, 9.99, 10.01, name="L", unit="mm"))
    rep.section("Machine")
    rep.figure(figures.residual_vectors(points, rng.normal(0, 2, (8, 3)), labels=list("abcdefgh")))
    rep.figure(figures.point_deviations(points, rng.normal(0, 2, 8)))
    rep.figure(figures.residual_profile(rng.normal(0, 2, 25)))
    rep.figure(figures.error_map(grid_x, grid_y, np.hypot.outer(grid_y, grid_x) / 10))
    rep.figure(figures.singular_values([3.0, 1.2, 0.4, 0.05]))
    rep.figure(figures.convergence([[1.0, 1.8, 2.1, 2.2], [0.7, 1.9, 2.2]]))
    lengths = {"length_mm": [100.0, 200.0, 300.0], "error_um": [0.5, -2.5, 1.0], "u_um": [1, 1, 1]}
    rep.figure(figures.length_errors({"kinematic": lengths, "GP": lengths}))
    check_page(browser, rep.write(tmp_path / "all.html"), 12, artefacts, "every-figure")


@pytest.mark.parametrize("command", sorted(COMMAND_FIGURES))
def test_command_report_in_the_browser(browser, artefacts, command_reports, command):
    result, page = command_reports[command]
    assert result.exit_code == 0, result.output
    check_page(browser, page, COMMAND_FIGURES[command], artefacts, f"mtm-{command}")


def test_a_page_with_an_error_is_caught(browser, tmp_path):
    """The check can fail: a page loading a missing image logs a console error."""
    page = tmp_path / "broken.html"
    page.write_text('<!DOCTYPE html><html><body><img src="missing.png"></body></html>')
    load = browser.load(page)
    assert load.console_errors and any(u.endswith("missing.png") for u in load.requests)


def test_cut_and_uncaptioned_figures_are_caught(browser, tmp_path):
    """The figure checks can fail: a text past the SVG's right edge, a marker half outside
    its clip rectangle, an offset label and an empty caption are each reported."""
    page = tmp_path / "cut.html"
    page.write_text(
        '<!DOCTYPE html><html><body><figure class="mtm-figure" data-figure="1">'
        '<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" '
        'width="200" height="100" viewBox="0 0 200 100">'
        '<defs><path id="m" d="M -5 0 L 5 0 L 0 5 z"/>'
        '<clipPath id="c"><rect x="20" y="20" width="100" height="60"/></clipPath></defs>'
        '<text x="20" y="95">+2.828e2</text><text x="170" y="50">cut off</text>'
        '<g clip-path="url(#c)"><use xlink:href="#m" x="60" y="50"/>'
        '<use xlink:href="#m" x="120" y="50"/></g>'
        "</svg><figcaption>Figure 1.</figcaption></figure></body></html>"
    )
    [fig] = browser.load(page).figures
    problems = figure_problems(fig)
    assert problems == [
        "outside the figure: text cut off",
        "marker cut by its axes: use #m",
        "axis offset text '+2.828e2'",
        "caption 'Figure 1.'",
    ], problems


def test_a_marker_at_the_axes_edge_is_caught(browser, tmp_path):
    """A matplotlib figure whose limits cut its end points in half: the browser finds the two
    cut markers (the SVG as a report writes it), and none once the limits have margins."""
    from matplotlib.figure import Figure

    def page(margin: float):
        fig = Figure(figsize=(4, 3))
        ax = fig.add_subplot()
        ax.plot([0.0, 0.5, 1.0], [0.0, 0.5, 1.0], "o", ms=10)
        ax.set_xlim(-margin, 1 + margin)
        ax.set_ylim(-margin, 1 + margin)
        rep = Report("edge")
        rep.figure(fig, caption="Three balls.")
        return rep.write(tmp_path / f"edge-{margin}.html")

    [cut] = browser.load(page(0.0)).figures
    problems = figure_problems(cut)
    assert len(problems) == 2 and all(p.startswith("marker cut by its axes: use") for p in problems)
    [kept] = browser.load(page(0.15)).figures
    assert figure_problems(kept) == []


def _doccheck():
    """tests/docs/doccheck.py, which runs a documentation page as the docs tests do."""
    import importlib.util
    import sys
    from pathlib import Path

    if "doccheck" in sys.modules:  # the docs tests ran in this session
        return sys.modules["doccheck"]
    path = Path(__file__).resolve().parents[1] / "docs" / "doccheck.py"
    spec = importlib.util.spec_from_file_location("doccheck", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules["doccheck"] = module  # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize(
    "page", ["tutorials/task-uncertainty.md", "tutorials/compensation.md", "tutorials/history.md"]
)
def test_the_reports_of_a_tutorial_pass_the_figure_checks(
    browser, artefacts, tmp_path, monkeypatch, page
):
    """Every report a tutorial writes (task and its conformity zones, repeatability,
    hysteresis, cov(e) campaigns, the export's tables and residual maps, the history's
    control charts): captioned figures, nothing cut, no axis offset."""
    import shutil
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    shutil.copytree(root / "examples", tmp_path / "examples")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("COLUMNS", "100")
    doc = root / "docs" / page
    _doccheck().run_page(page, doc.read_text(encoding="utf-8"), tmp_path)
    reports = sorted(p for p in tmp_path.rglob("*.html") if "examples" not in p.parts)
    loads = [browser.load(report) for report in reports]
    assert sum(len(load.figures) for load in loads) > 0, page
    for report, load in zip(reports, loads, strict=True):
        for fig in load.figures:
            assert figure_problems(fig) == [], (report.name, fig["number"], figure_problems(fig))
