"""Tests of mtmetrology.report.figures.machines: what the figures of fits, error maps and
iterations draw."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.report import figures


def test_residual_vectors_default_magnification_is_a_tenth_of_the_extent():
    pts = np.array([[0.0, 0, 0], [200.0, 0, 0], [0, 100.0, 50.0]])
    res = np.array([[2.0, 0, 0], [0, 1.0, 0], [0, 0, 0.5]])
    fig = figures.residual_vectors(pts, res)
    quiver = fig.axes[0].collections[-1]
    assert np.max(np.hypot(quiver.U, quiver.V)) == pytest.approx(20.0)
    with pytest.raises(ValueError, match=r"got \(3, 3\) and \(2, 3\)"):
        figures.residual_vectors(pts, res[:2])


def test_error_map_grid_and_scattered_forms():
    gx, gy = np.linspace(0, 1, 4), np.linspace(0, 1, 3)
    assert len(figures.error_map(gx, gy, np.zeros((3, 4))).axes) == 2
    rng = np.random.default_rng(0)
    x, y = rng.random(20), rng.random(20)
    assert len(figures.error_map(x, y, x + y).axes) == 2
    with pytest.raises(ValueError, match=r"got \(4,\), \(3,\), \(4, 3\)$"):
        figures.error_map(gx, gy, np.zeros((4, 3)))


def test_convergence_one_curve_or_several():
    assert len(figures.convergence([1.0, 2.0]).axes[0].lines) == 1
    assert len(figures.convergence([[1.0, 2.0], np.array([0.5, 1.5, 2.0])]).axes[0].lines) == 2
