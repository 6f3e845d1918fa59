"""IdentificationResult.variance_factor: s² = ‖r‖²/(m − rank), its law and its absence.

With weights equal to the true input standard uncertainties the residuals are chi-squared:
(m − n)·s² ~ χ²(m − n), so E[s²] = 1 and Var[s²] = 2/(m − n) (Sepahi Boroujeni (2021),
eq. 5-6; JCGM 100:2008 §H.3 for the residual standard deviation of a fit).
"""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.identification import levenberg_marquardt


class Polynomial:
    """y = Σ x_k t^k observed with standard uncertainty sigma (weighted residuals)."""

    def __init__(self, t, y, degree, sigma):
        self.t, self.y, self.sigma = np.asarray(t), np.asarray(y), sigma
        self.design = np.vander(self.t, degree + 1, increasing=True)
        self.names = tuple(f"x{k}" for k in range(degree + 1))

    def initial(self):
        return np.zeros(self.design.shape[1])

    def evaluate(self, x, jacobian=True):
        return (self.design @ x - self.y) / self.sigma, self.design / self.sigma


def test_variance_factor_is_the_weighted_residual_sum_over_the_redundancy():
    """Against numpy's lstsq residual sum of squares (an independent solver)."""
    rng = np.random.default_rng(3)
    t = np.linspace(-1.0, 1.0, 9)
    y = 0.3 - 1.2 * t + 0.5 * t**2 + 0.01 * rng.standard_normal(9)
    problem = Polynomial(t, y, 2, sigma=0.01)
    res = levenberg_marquardt(problem)
    _, rss, rank, _ = np.linalg.lstsq(problem.design / 0.01, y / 0.01, rcond=None)
    assert rank == 3 and res.dof == 6
    assert res.variance_factor == pytest.approx(rss[0] / 6, rel=1e-9)
    assert res.cost == pytest.approx(0.5 * rss[0], rel=1e-9)


def test_variance_factor_scales_with_the_inverse_square_of_the_weights():
    """Stating the input uncertainty twice too small makes s² four times larger."""
    rng = np.random.default_rng(4)
    t = np.linspace(0.0, 2.0, 12)
    y = 1.0 + 2.0 * t + 0.02 * rng.standard_normal(12)
    honest = levenberg_marquardt(Polynomial(t, y, 1, sigma=0.02)).variance_factor
    optimistic = levenberg_marquardt(Polynomial(t, y, 1, sigma=0.01)).variance_factor
    assert optimistic == pytest.approx(4.0 * honest, rel=1e-9)


def test_variance_factor_follows_chi_squared_over_its_degrees_of_freedom():
    """400 fits with m − n = 10 and the true σ as weights: the mean of s² is 1 within
    4·sqrt(2/10/400) (= 0.089; a two-sided level of about 6e-5 under the normal
    approximation), and its variance is 2/10 within 35 % (about 5 standard errors)."""
    rng = np.random.default_rng(2021)
    t = np.linspace(-1.0, 1.0, 13)
    truth = np.array([0.5, -0.2, 0.1])
    sigma = 0.005
    s2 = []
    for _ in range(400):
        y = np.vander(t, 3, increasing=True) @ truth + sigma * rng.standard_normal(t.size)
        s2.append(levenberg_marquardt(Polynomial(t, y, 2, sigma)).variance_factor)
    s2 = np.array(s2)
    assert abs(s2.mean() - 1.0) < 4.0 * np.sqrt(2.0 / 10.0 / 400.0)
    assert s2.var(ddof=1) == pytest.approx(2.0 / 10.0, rel=0.35)


def test_no_redundancy_no_variance_factor():
    """m = n: the fit passes through the data, s² is undefined (None), never NaN or 0."""
    t = np.array([0.0, 1.0, 2.0])
    res = levenberg_marquardt(Polynomial(t, [1.0, 0.0, 5.0], 2, sigma=1.0))
    assert res.success and res.dof == 0 and res.variance_factor is None
    np.testing.assert_allclose(res.residuals, 0.0, atol=1e-12)


def test_minimum_norm_solution_counts_redundancy_against_the_rank():
    """Two identical columns: rank 1 of 2, m = 5, so m − rank = 4 degrees of freedom."""

    class Twin:
        names = ("a", "b")
        t = np.arange(5.0)

        def initial(self):
            return np.zeros(2)

        def evaluate(self, x, jacobian=True):
            design = np.column_stack([np.ones(5), np.ones(5)])
            y = np.array([1.0, 1.1, 0.9, 1.05, 0.95])
            return design @ x - y, design

    res = levenberg_marquardt(Twin(), minimum_norm=True)
    assert res.minimum_norm and res.dof == 4
    y = np.array([1.0, 1.1, 0.9, 1.05, 0.95])
    assert res.variance_factor == pytest.approx(np.sum((y - y.mean()) ** 2) / 4, rel=1e-9)
    np.testing.assert_allclose(res.estimate, [y.mean() / 2] * 2, rtol=1e-9)
