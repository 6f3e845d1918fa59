"""The circular-test report: the ISO 230-4 table and one polar trace per test."""

from __future__ import annotations

import numpy as np

from mtmetrology.ballbar.iso230_4 import circular_results
from mtmetrology.ballbar.records import BallbarConditions, nominal_test
from mtmetrology.ballbar.report import analysis_report
from mtmetrology.ballbar.requests import CircularAnalysis
from mtmetrology.report.figures import circular_trace


def test_report_has_the_table_and_a_trace_per_test():
    test = nominal_test(BallbarConditions("XY", 100.0, 1000.0, np.zeros(3), name="t1"), 72)
    test = test.with_reading(2e-3 * np.cos(2 * test.angle))
    rep = analysis_report(CircularAnalysis("m", (test,), (circular_results(test),)))
    page = rep.html()
    assert page.count("<svg") == 1
    assert "Test t1: XY, R = 100 mm" in page


def test_trace_draws_each_run_on_the_zero_ring():
    a = np.arange(0.0, 360.0, 5.0)
    fig = circular_trace(a, {"ccw": np.sin(np.radians(a)), "cw": -np.sin(np.radians(a))})
    ax = fig.axes[0]
    ring, ccw, cw = ax.lines
    assert np.all(ring.get_ydata() == 0.0)
    # each run closed on itself: the first point repeated at the end
    assert ccw.get_ydata()[0] == ccw.get_ydata()[-1]
    assert ax.get_rorigin() < min(ccw.get_ydata().min(), cw.get_ydata().min())
