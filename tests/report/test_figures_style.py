"""Tests of mtmetrology.report.figures.style: no axis of a report figure shows an offset or a
multiplier, legends lie outside the data, nothing of a residual projection is cut off."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.ticker import ScalarFormatter

from mtmetrology.report import figures
from mtmetrology.report.document import figure_svg
from mtmetrology.report.figures.style import plain_ticks

#: Values that make matplotlib write an offset or multiplier on a default axis: a gauge
#: length of 282.8426 mm varying in its fifth decimal, a length of 5·10⁷ nm varying in nm,
#: deviations of 10⁻⁵ mm.
GAUGE = 282.8426 + np.array([0.0, 1e-5, 3e-5, 2e-5])
NM = 50_000_839.0 + np.array([-40.0, 0.0, 35.0, 10.0])
TINY = np.array([1e-5, -2e-5, 3e-5, 0.5e-5])


def _every_figure() -> dict[str, Figure]:
    """Every figure function of mtmetrology.report.figures with offset-prone data."""
    rng = np.random.default_rng(3)
    cov = np.diag([1e-10, 4e-10])
    points = np.column_stack([GAUGE, GAUGE - 282.0, NM / 1e6])
    dates = [datetime(2026, 1, 1, tzinfo=UTC) + timedelta(days=30 * i) for i in range(4)]
    lengths = {"length_mm": GAUGE, "error_um": TINY, "u_um": [1e-5] * 4}
    return {
        "histogram_vs_normal": figures.histogram_vs_normal(
            rng.normal(NM[1], 30.0, 2000), NM[1], 30.0, "l", "nm", interval=(NM[0], NM[2])
        ),
        "coverage_ellipses": figures.coverage_ellipses(
            ["a", "b"],
            [GAUGE[0], 1e-5],
            cov,
            samples=rng.multivariate_normal([GAUGE[0], 0], cov, 50),
        ),
        "conformity_zones": figures.conformity_zones(
            GAUGE[1], 2e-5, 282.8425, 282.8427, name="L", unit="mm"
        ),
        "residual_vectors": figures.residual_vectors(points, rng.normal(0, 1, (4, 3))),
        "point_deviations": figures.point_deviations(points, TINY),
        "residual_profile": figures.residual_profile(GAUGE),
        "error_map": figures.error_map(GAUGE[:3], GAUGE[:3] - 100, np.outer(TINY[:3], [1, 2, 3])),
        "convergence": figures.convergence([GAUGE, GAUGE + 1e-5]),
        "length_errors": figures.length_errors({"kinematic": lengths}),
        "correlation_heatmap": figures.correlation_heatmap(["a", "b"], np.eye(2)),
        "budget_bars": figures.budget_bars(["a", "b"], [0.3, 0.7]),
        "singular_values": figures.singular_values([3.0, 1.2, 0.4]),
        "control_chart": figures.control_chart(
            dates, GAUGE, GAUGE.mean(), (GAUGE.min(), GAUGE.max()), [False] * 4, name="L", unit="mm"
        ),
        "hysteresis_bars": figures.hysteresis_bars([0, 30, 60, 90], TINY, [1e-5] * 4),
        "circular_trace": figures.circular_trace(
            np.arange(0.0, 360.0, 10.0), {"ccw": NM[1] + np.zeros(36), "cw": NM[2] + np.zeros(36)}
        ),
        "window_repeatability": figures.window_repeatability(
            {"sigma_X": [([2, 3, 4, 5], GAUGE)]}, window=10
        ),
    }


def _renderer(fig: Figure):
    """The Agg renderer of ``fig`` after a draw (the boxes of texts and legends)."""
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return canvas.get_renderer()


def _offsets(fig: Figure) -> list[str]:
    fig.draw_without_rendering()
    return [
        axis.get_major_formatter().get_offset()
        for ax in fig.axes
        for axis in (ax.xaxis, ax.yaxis)
        if isinstance(axis.get_major_formatter(), ScalarFormatter)
        and axis.get_major_formatter().get_offset()
    ]


def test_every_figure_function_is_covered() -> None:
    assert set(_every_figure()) | {"parameter_table_columns", "parameter_table_rows"} == set(
        figures.__all__
    )


@pytest.mark.parametrize("name", sorted(_every_figure()))
def test_no_axis_has_an_offset_or_multiplier(name: str) -> None:
    """After drawing, every linear axis formats its ticks as plain values."""
    assert _offsets(_every_figure()[name]) == []


def test_the_data_would_give_offsets_on_a_default_axis() -> None:
    """The check can fail: the same values on a plain matplotlib axis get an offset and a
    multiplier, and plain_ticks removes both (a figure made outside report.figures)."""
    fig = Figure()
    ax = fig.add_subplot()
    ax.plot(GAUGE, TINY)
    assert len(_offsets(fig)) == 2  # x: "1e−5+2.82842e2", y: "1e−5"
    assert _offsets(plain_ticks(fig)) == []


def test_figure_svg_writes_no_offset_for_a_figure_built_elsewhere() -> None:
    fig = Figure()
    fig.add_subplot().plot(NM, TINY)
    svg = figure_svg(fig)
    assert "e7" not in svg and "1e−5" not in svg and "5e7" not in svg


def test_legends_lie_outside_every_axes() -> None:
    """A legend under the figure covers no data: its box meets no axes' box."""
    for name in ("histogram_vs_normal", "coverage_ellipses", "conformity_zones", "convergence"):
        fig = _every_figure()[name]
        renderer = _renderer(fig)
        [legend] = fig.legends
        box = legend.get_window_extent(renderer)
        assert all(ax.get_legend() is None for ax in fig.axes), name
        assert not any(box.overlaps(ax.get_window_extent(renderer)) for ax in fig.axes), name


def test_residual_projections_hold_every_point_label_and_arrow_tip() -> None:
    """Points at the edge of the artefact, long arrows: each projection's limits hold the
    points and the arrow tips with room to spare, and each label lies inside its axes."""
    points = np.array([[0.0, 0, 0], [500, 0, 0], [0, 400, 0], [500, 400, 300]])
    residuals = np.array([[5.0, -5, 0], [5, 0, 5], [-5, 5, 0], [5, 5, 5]])
    fig = figures.residual_vectors(points, residuals, magnification=30.0, labels=list("abcd"))
    renderer = _renderer(fig)
    tips = points + residuals * 30.0  # arrows of up to 260 mm on a 500 mm artefact
    for ax, (i, j) in zip(fig.axes, ((0, 1), (0, 2), (1, 2)), strict=True):
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        for p in (points, tips):
            assert np.all((p[:, i] > x0) & (p[:, i] < x1) & (p[:, j] > y0) & (p[:, j] < y1))
        frame = ax.get_window_extent(renderer)
        for text in ax.texts:
            box = text.get_window_extent(renderer)
            assert frame.x0 <= box.x0 and box.x1 <= frame.x1, text.get_text()
            assert frame.y0 <= box.y0 and box.y1 <= frame.y1, text.get_text()
