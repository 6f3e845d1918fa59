"""The source's GP (Salacheep 2016, Ch. 5, Appendix 3) against the digest's checked numbers."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import approx_fprime

from mtmetrology.cmm.gpml import (
    ParametricGP,
    SourceGPDemo,
    fit_parametric_gp,
    gpml_randn,
    negative_log_marginal_likelihood,
    source_gp_data,
    source_gp_demo,
)
from mtmetrology.errors import InputError


@pytest.fixture(scope="module")
def demo() -> SourceGPDemo:
    return source_gp_demo()


def test_gpml_randn_seed_001_matches_digest_t5():
    expected = [-1.70974862, -1.13294317, -1.35885826, 1.20314673, -1.43201539,
                -1.54770308, 0.64255419, 0.34041182, -0.75581425]  # fmt: skip
    np.testing.assert_allclose(gpml_randn(0.01, 9), expected, atol=5e-9)


def test_gpml_randn_odd_count_is_prefix_of_next_even_count_as_in_gpml():
    # GPML draws N = 2⌈n/2⌉ uniforms: n = 9 and n = 10 share them, n = 8 does not
    np.testing.assert_array_equal(gpml_randn(0.01, 9), gpml_randn(0.01, 10)[:9])
    assert gpml_randn(0.01, 8)[0] != gpml_randn(0.01, 9)[0]


def test_source_targets_are_scaled_to_max_002_digest_t5():
    x, y = source_gp_data()
    expected = [-0.02842128, -0.01883300, -0.02258840, 0.02000000, -0.02380450,
                -0.02572759, 0.01068123, 0.00565869, -0.01256396]  # fmt: skip
    np.testing.assert_allclose(y, expected, atol=5e-9)
    # inputs: ball positions (x fastest) shifted by the same noise in both coordinates
    np.testing.assert_allclose(x[1] - y[1], [0.5, 0.4])
    np.testing.assert_allclose(
        x[:, 0] - x[:, 1], np.tile([0.0, 0.1, 0.2], 3) - np.repeat([0.0, 0.1, 0.2], 3)
    )


@pytest.mark.parametrize("mean", ["zero", "quadratic-x1"])
def test_nlml_gradient_is_the_derivative(mean):
    x, y = source_gp_data()
    h = np.array([0.1, 0.5, -0.3, -2.0, -4.0, -4.4])[(3 if mean == "zero" else 0) :]
    _, grad = negative_log_marginal_likelihood(h, x, y, mean)
    num = approx_fprime(h, lambda v: negative_log_marginal_likelihood(v, x, y, mean)[0], 1e-7)
    np.testing.assert_allclose(grad, num, rtol=1e-5, atol=1e-4)


def test_zero_mean_gp_reaches_source_t3_start_digest_t5b(demo):
    """The zero-mean optimum is the source's hard-coded stage-T3 start (digest T5b)."""
    log_l, log_sf, log_sn = demo.zero_mean.hyperparameters
    assert log_l == pytest.approx(-2.013713, abs=5e-7)
    assert log_sf == pytest.approx(-4.082864, abs=5e-7)
    assert log_sn == pytest.approx(-4.485944, abs=5e-7)
    assert demo.zero_mean.nlml == pytest.approx(-24.02731, abs=5e-6)


def test_quadratic_mean_difference_map_is_below_0011_digest_t5c(demo):
    """Source §5.4: "less than 0.011 µm" — the unit is mislabelled (the targets are the
    adjusted noise, max 0.02, in the code's units); the number is reproduced."""
    assert demo.quadratic_mean.nlml < demo.zero_mean.nlml  # three more parameters
    assert 0.010 < demo.max_difference < 0.011
    assert demo.to_dict()["max_difference_at"] == pytest.approx([0.6, 0.6])


def test_prediction_at_a_training_input_interpolates_within_noise(demo):
    gp = demo.zero_mean
    m, s2 = gp.predict(gp.inputs)
    sn2 = np.exp(2 * gp.hyperparameters[-1])
    assert np.all(s2 >= sn2) and np.all(s2 < sn2 + np.exp(2 * gp.hyperparameters[-2]))
    assert np.max(np.abs(m - gp.targets)) < 3 * np.sqrt(sn2)


def test_quadratic_mean_recovers_a_quadratic_in_small_noise():
    """Targets that are the mean plus white noise of 1e-4: β within a few noise units."""
    rng = np.random.default_rng(3)
    x = rng.uniform(0, 1, (30, 2))
    y = 0.3 - 0.5 * x[:, 0] + 0.8 * x[:, 0] ** 2 + 1e-4 * rng.standard_normal(30)
    gp = fit_parametric_gp(x, y, "quadratic-x1", [0, 0, 0, -1.0, -3.0, -6.0])
    np.testing.assert_allclose(gp.beta, [0.3, -0.5, 0.8], atol=2e-3)
    assert np.exp(gp.hyperparameters[-1]) == pytest.approx(1e-4, rel=0.5)


def test_round_trip(demo):
    back = SourceGPDemo.from_dict(demo.to_dict())
    assert back.to_dict() == demo.to_dict()
    z = demo.grid[:5]
    np.testing.assert_array_equal(
        ParametricGP.from_dict(demo.quadratic_mean.to_dict()).predict(z)[0],
        demo.quadratic_mean.predict(z)[0],
    )


def test_bad_inputs_raise_one_line_errors():
    x, y = source_gp_data()
    with pytest.raises(InputError, match="mean 'cubic'"):
        fit_parametric_gp(x, y, "cubic")
    with pytest.raises(InputError, match="needs 6"):
        fit_parametric_gp(x, y, "quadratic-x1", [0, 0, 0])
    with pytest.raises(InputError, match="finite"):
        fit_parametric_gp(x, np.where(np.arange(9) == 2, np.nan, y))
