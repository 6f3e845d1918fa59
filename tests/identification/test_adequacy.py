"""The model-adequacy rule of the identification engine (identification/adequacy.py):
s² = χ²/ν and p = P(χ²_ν ≥ χ²) of the weighted residuals, the covariance scaled by s² only
when p < 0.01 (rule "scale"), kept with rule "a-priori"; the residual RMS by group."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from mtmetrology.errors import InputError
from mtmetrology.identification import levenberg_marquardt
from mtmetrology.identification.adequacy import ModelAdequacy, model_adequacy, residual_patterns


class Line:
    """y = a + b t observed with stated standard uncertainty sigma (weighted residuals)."""

    names = ("a", "b")

    def __init__(self, t, y, sigma):
        self.t, self.y, self.sigma = np.asarray(t, float), np.asarray(y, float), sigma
        self.design = np.column_stack([np.ones_like(self.t), self.t])

    def initial(self):
        return np.zeros(2)

    def evaluate(self, x, jacobian=True):
        return (self.design @ x - self.y) / self.sigma, self.design / self.sigma


def _line(noise, stated, seed, n=30):
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 10.0, n)
    y = 2.0 - 0.5 * t + noise * rng.standard_normal(n)
    return Line(t, y, stated), y


def test_variance_factor_and_p_value_of_a_linear_model_in_closed_form():
    """χ² = ‖(y − X β̂)/σ‖² from numpy's lstsq (closed form), ν = n − 2, p from scipy."""
    problem, y = _line(noise=0.03, stated=0.01, seed=1)
    res = levenberg_marquardt(problem).with_adequacy()
    beta, rss, _, _ = np.linalg.lstsq(problem.design, y, rcond=None)
    chi2 = rss[0] / 0.01**2
    a = res.adequacy
    assert a.dof == 28
    assert a.chi2 == pytest.approx(chi2, rel=1e-9)
    assert a.variance_factor == pytest.approx(chi2 / 28, rel=1e-9)
    assert a.p_value == pytest.approx(stats.chi2.sf(chi2, 28), rel=1e-6)
    # noise three times the stated one: s² ≈ 9, the test rejects and scales by s²
    assert a.significant and a.scaled and a.factor == pytest.approx(chi2 / 28, rel=1e-9)
    cov0 = np.linalg.inv(problem.design.T @ problem.design) * 0.01**2
    np.testing.assert_allclose(res.covariance, cov0 * chi2 / 28, rtol=1e-8)
    np.testing.assert_allclose(res.estimate, beta, rtol=1e-9)


def test_option_keeps_the_a_priori_covariance_and_says_so():
    problem, _ = _line(noise=0.03, stated=0.01, seed=1)
    plain = levenberg_marquardt(problem)
    kept = plain.with_adequacy("a-priori")
    assert kept.adequacy.significant and not kept.adequacy.scaled and kept.adequacy.factor == 1.0
    np.testing.assert_array_equal(kept.covariance, plain.covariance)
    assert kept.adequacy.rule == "a-priori"
    scaled = plain.with_adequacy("scale")
    assert scaled.adequacy.scaled
    assert np.all(np.diag(scaled.covariance) > 4.0 * np.diag(plain.covariance))


def test_no_scaling_when_the_stated_noise_is_right_or_too_large():
    """Honest noise: p ≥ 0.01 here (fixed seed) and the covariance is untouched; stated
    noise ten times too large: s² ≈ 0.01, never scaled down."""
    honest = levenberg_marquardt(_line(noise=0.01, stated=0.01, seed=2)[0]).with_adequacy()
    assert honest.adequacy.p_value >= 0.01 and not honest.adequacy.scaled
    cautious = levenberg_marquardt(_line(noise=0.01, stated=0.1, seed=2)[0])
    after = cautious.with_adequacy()
    assert after.adequacy.variance_factor < 0.1
    assert not after.adequacy.significant and after.adequacy.factor == 1.0
    np.testing.assert_array_equal(after.covariance, cautious.covariance)


def test_scaling_follows_the_threshold_exactly():
    """At ν = 20: χ² just above the 99 % quantile scales, just below does not."""
    q = stats.chi2.isf(0.01, 20)
    above, below = model_adequacy(q * 1.001, 20), model_adequacy(q * 0.999, 20)
    assert above.scaled and above.factor == pytest.approx(q * 1.001 / 20)
    assert not below.scaled and below.factor == 1.0
    assert model_adequacy(q * 0.999, 20, alpha=0.05).scaled


def test_rule_is_applied_once_and_round_trips():
    problem, _ = _line(noise=0.03, stated=0.01, seed=1)
    res = levenberg_marquardt(problem).with_adequacy()
    with pytest.raises(InputError, match="already"):
        res.with_adequacy()
    assert ModelAdequacy.from_dict(res.adequacy.to_dict()) == res.adequacy
    with pytest.raises(InputError, match="rule"):
        model_adequacy(1.0, 1, rule="shrink")
    with pytest.raises(InputError, match="significance"):
        model_adequacy(1.0, 1, alpha=1.5)


def test_no_redundancy_is_not_tested():
    a = model_adequacy(0.0, 0)
    assert a.variance_factor is None and a.p_value is None and not a.scaled and a.factor == 1.0


def test_scaled_coverage_with_noise_twice_the_stated_one():
    """2000 straight-line fits with the noise twice the stated one: the scaled 2u of the
    slope covers its true value at 95.4 % (t-like with ν = 28: the binomial 99 % region of
    0.954 over 2000 is about ±1.2 %); with the a-priori u it covers about 68 %."""
    rng = np.random.default_rng(7)
    t = np.linspace(0.0, 10.0, 30)
    design = np.column_stack([np.ones_like(t), t])
    y = 2.0 - 0.5 * t + 0.02 * rng.standard_normal((2000, 30))
    beta = np.linalg.lstsq(design, y.T, rcond=None)[0].T
    chi2 = np.sum((y - beta @ design.T) ** 2, axis=1) / 0.01**2
    u0 = np.sqrt(np.linalg.inv(design.T @ design)[1, 1]) * 0.01
    factors = np.array([model_adequacy(c, 28).factor for c in chi2])
    covered = np.abs(beta[:, 1] + 0.5) <= 2.0 * u0 * np.sqrt(factors)
    lo, hi = stats.binom.interval(0.99, 2000, 2 * stats.t.cdf(2.0, 28) - 1)
    assert lo <= covered.sum() <= hi
    assert np.mean(np.abs(beta[:, 1] + 0.5) <= 2.0 * u0) < 0.75


def test_residual_patterns_by_group():
    """Vector residuals: RMS = sqrt(mean ‖r‖²) per group, per component, in µm."""
    r = np.array([[3e-3, 4e-3, 0.0], [0.0, 0.0, 0.0], [1e-3, 0.0, 0.0], [1e-3, 0.0, 0.0]])
    out = residual_patterns(r, {"tool": ["A", "A", "B", "B"]}, weighted=r / 1e-3)
    a, b = out["tool"]
    assert a["group"] == "A" and a["n"] == 2
    assert a["rms_µm"] == pytest.approx(np.sqrt(25.0 / 2))
    assert a["rms_µm_components"] == pytest.approx([np.sqrt(4.5), np.sqrt(8.0), 0.0])
    assert b["rms_µm"] == pytest.approx(1.0)
    assert b["rms_weighted"] == pytest.approx(np.sqrt(1.0 / 3.0))
    assert out["component"] == pytest.approx([np.sqrt(11 / 4), 2.0, 0.0])
    scalar = residual_patterns(np.array([1e-3, -3e-3]), {"station": ["S1", "S2"]})
    assert [g["rms_µm"] for g in scalar["station"]] == pytest.approx([1.0, 3.0])
    assert "component" not in scalar
    with pytest.raises(ValueError, match="labels"):
        residual_patterns(r, {"tool": ["A"]})
