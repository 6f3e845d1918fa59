"""Tests of mtmetrology.report.figures.uncertainty: what each figure of a result and its
uncertainty draws."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.report import figures
from mtmetrology.report.figures.uncertainty import _ellipse


def test_ellipse_points_lie_on_the_mahalanobis_contour():
    """(x − c)ᵀ Σ⁻¹ (x − c) = k² on every drawn point (exact for any covariance)."""
    cov = np.array([[4.0, 1.5], [1.5, 1.0]])
    k = float(np.sqrt(stats.chi2.ppf(0.95, 2)))
    pts = _ellipse([3.0, -1.0], cov, k) - [3.0, -1.0]
    q = np.einsum("ni,ij,nj->n", pts, np.linalg.inv(cov), pts)
    np.testing.assert_allclose(q, k**2, rtol=1e-12)


@pytest.mark.parametrize(
    ("value", "decision"),
    [
        (10.000, "conformity proven"),
        (10.009, "neither conformity nor nonconformity proven"),
        (10.014, "nonconformity proven"),
        (9.988, "neither conformity nor nonconformity proven"),
    ],
)
def test_conformity_zones_iso_14253_1_decision(value, decision):
    """Spec [9.990, 10.010] mm, U = 0.003 mm: conformance zone [9.993, 10.007]."""
    title = figures.conformity_zones(value, 0.003, 9.990, 10.010, unit="mm").axes[0].get_title()
    assert title.endswith(f": {decision}")


def test_conformity_zones_one_sided_and_bad_limits():
    fig = figures.conformity_zones(2.0, 0.5, None, 3.0, name="flatness", unit="µm")
    assert fig.axes[0].get_title().endswith("conformity proven")
    with pytest.raises(ValueError, match="needs at least one limit"):
        figures.conformity_zones(1.0, 0.1, None, None)
    with pytest.raises(ValueError, match=r"lower limit 2\.0 must be below upper limit 1\.0"):
        figures.conformity_zones(1.0, 0.1, 2.0, 1.0)


def test_parameter_rows_follow_the_parameter_set_document():
    m = Machine.load("five-axis-wcbxfzyst")
    n = m.n_params
    values = np.linspace(-1e-4, 1e-4, n)
    cov = np.diag(np.full(n, 1e-12))
    pset = ParameterSet(m.parameter_names, values, m.parameter_units, cov)
    rows = figures.parameter_table_rows(pset, coverage_factor=2.0)
    doc = pset.to_document()["parameters"]
    assert [r[0] for r in rows] == list(m.parameter_names)
    assert [r[2] for r in rows] == list(m.parameter_units)
    for row, entry in zip(rows, doc, strict=True):
        assert float(row[1]) == pytest.approx(entry["value"], abs=float(row[3]))
        assert float(row[4]) == pytest.approx(2 * float(row[3]), rel=0.05)


def test_parameter_rows_without_covariance_show_dashes():
    m = Machine.load("five-axis-wcbxfzyst")
    rows = figures.parameter_table_rows(ParameterSet.zeros(m))
    assert {r[3] for r in rows} == {"—"} and {r[4] for r in rows} == {"—"}


def test_histogram_vs_normal_takes_a_histogram_and_draws_the_t_law():
    from mtmetrology.uncertainty.regions import histogram

    h = histogram(np.random.default_rng(3).normal(5.0, 2.0, 4000), 50)
    ax = figures.histogram_vs_normal(h, 5.0, 2.0, "y", "mm", dof=4.0).axes[0]
    x, pdf = ax.lines[0].get_data()
    np.testing.assert_allclose(pdf, stats.t.pdf((x - 5.0) / 2.0, 4.0) / 2.0)


def test_budget_bars_sorted_by_magnitude_with_signed_shares():
    """Bars show the given variance shares, a negative one (correlations) to the left."""
    ax = figures.budget_bars(["a", "b", "c"], [-0.25, 1.25, 0.0]).axes[0]
    assert [t.get_text() for t in ax.get_yticklabels()] == ["c", "a", "b"]
    assert [t.get_text().strip() for t in ax.texts] == ["0.0 %", "-25.0 %", "125.0 %"]
    widths = [patch.get_width() for patch in ax.patches]
    assert widths == pytest.approx([0.0, -25.0, 125.0])


def test_coverage_ellipses_pairs_and_shape_checks():
    fig = figures.coverage_ellipses(list("abcd"), np.zeros(4), np.eye(4), max_pairs=6)
    assert len(fig.axes) == 6
    with pytest.raises(ValueError, match="m >= 2 names"):
        figures.coverage_ellipses(["a"], [0.0], [[1.0]])


def test_correlation_heatmap_refuses_a_wrong_shape():
    with pytest.raises(ValueError, match=r"2 x 2 for 2 names, got \(3, 3\)"):
        figures.correlation_heatmap(["a", "b"], np.eye(3))
