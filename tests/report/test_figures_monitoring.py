"""Tests of mtmetrology.report.figures.monitoring: what the figures of a machine over time
draw."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta, timezone

import numpy as np
import pytest

from mtmetrology.report import figures


def test_window_repeatability_draws_the_median_over_targets_at_each_start():
    series = {"sigma_X": [([2, 3], [0.5, 0.6]), ([2, 3], [0.4, 0.8]), ([3], [1.0])]}
    fig = figures.window_repeatability(series, window=10)
    median = fig.axes[0].lines[-1]
    np.testing.assert_array_equal(median.get_xdata(), [2, 3])
    np.testing.assert_allclose(median.get_ydata(), [0.45, 0.8])
    with pytest.raises(ValueError, match="at least one target"):
        figures.window_repeatability({"sigma_X": []}, window=10)


def test_hysteresis_bars_are_plus_minus_k_u():
    fig = figures.hysteresis_bars([0.0, 30.0], [0.1, -0.2], [0.15, 0.2], coverage_factor=2.0)
    bars = fig.axes[0].containers[-1]  # the error bars' line collection
    segments = bars.lines[2][0].get_segments()
    np.testing.assert_allclose([s[:, 1] for s in segments], [[-0.2, 0.4], [-0.6, 0.2]])
    with pytest.raises(ValueError, match="1-D of one non-zero length"):
        figures.hysteresis_bars([0.0], [0.1, 0.2], [0.1, 0.1])


def test_control_chart_places_aware_dates_in_utc_and_flags_points_in_red():
    """09:00 at UTC+2 and 07:00 UTC are the same instant: both points at one abscissa."""
    dates = [
        datetime(2026, 1, 5, 9, 0, tzinfo=timezone(timedelta(hours=2))),
        datetime(2026, 1, 5, 7, 0, tzinfo=UTC),
        datetime(2026, 1, 6, 7, 0),  # naive: taken as UTC
    ]
    fig = figures.control_chart(
        dates, [1.0, 2.0, 9.0], 2.0, (-1.0, 5.0), [False, False, True], name="E_XX", unit="µm"
    )
    values, flagged = fig.axes[0].lines[:2]
    x = values.get_xdata()
    assert x[0] == x[1] == np.datetime64("2026-01-05T07:00:00")
    assert x[2] == np.datetime64("2026-01-06T07:00:00")
    np.testing.assert_array_equal(flagged.get_ydata(), [9.0])
