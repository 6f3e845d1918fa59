"""Gauss-Newton identification of SAMBA set-ups: round trips and noise propagation."""

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.identification import (
    BallCentreProblem,
    IdentificationError,
    ScaleBar,
    levenberg_marquardt,
    senses_from_sequence,
)
from mtmetrology.kinematics import Machine
from mtmetrology.samba import probing_sequence

GRID_PAIRS = [(b, c) for b in (-90, -45, 0, 45, 90) for c in range(0, 360, 60)]


def true_errors(m: Machine, rng, magnitude=50.0):
    """Realistic errors: ~50 µm, µrad, µm/m (digest 004 §5.2: 10-300 µrad, 10-100 µm/m)."""
    return magnitude * rng.uniform(-1, 1, m.n_params) * m.parameter_scales


def simulate(m, setup, pairs, theta, *, noise=0.0, rng=None, backlash=False, tool_error=None):
    ids, q0 = probing_sequence(m, setup, pairs)
    senses = senses_from_sequence(q0) if backlash else None
    tool = m.tool + (np.zeros(3) if tool_error is None else tool_error)
    targets = np.array([setup.balls.get(i, setup.scale_bar.get(i)) for i in ids], dtype=float)
    q = m.inverse(targets, q0, theta, senses=senses, tool=tool)
    if noise:
        lin = [m.axis_names.index(a) for a in m.linear_axes]
        q[:, lin] += noise * rng.standard_normal((q.shape[0], 3))
    length = setup.scale_bar_length
    if noise:  # the calibrated length is uncertain too: draw the certificate error
        length += 0.001 * rng.standard_normal()
    bar = ScaleBar(("SB1", "SB2"), length, u=0.001)
    return BallCentreProblem(
        m, q, ids, senses=senses, scale_bars=[bar], estimate_tool=True, sigma=0.001
    )


def test_noise_free_13_parameter_round_trip(samba_setup):
    """Digest 004 §5.2: recover every parameter to < 1e-9 relative in a few iterations."""
    m = Machine.load("five-axis-wcbxfzyst")
    rng = np.random.default_rng(3)
    theta = true_errors(m, rng)
    tool_error = np.array([0.02, -0.03, 0.05])
    result = levenberg_marquardt(simulate(m, samba_setup, GRID_PAIRS, theta, tool_error=tool_error))
    assert result.success and result.nit <= 6
    est = result.estimate[: m.n_params]
    np.testing.assert_allclose(est, theta, rtol=1e-9, atol=1e-12 * np.abs(theta).max())
    np.testing.assert_allclose(result.estimate[-3:], tool_error, atol=1e-10)
    balls = result.estimate[m.n_params : m.n_params + 3].reshape(1, 3)
    np.testing.assert_allclose(balls[0], samba_setup.balls["1"], atol=1e-9)
    j = m.parameter_names.index("E_XX1")
    assert result.value("E_XX1") == result.estimate[j]
    assert result.u("E_XX1") == result.standard_uncertainty[j]
    with pytest.raises(InputError, match="'E_Q0Q': not an unknown"):
        result.value("E_Q0Q")
    pset = result.parameter_set(m)
    assert pset.names == m.parameter_names and pset.units[8] == "µm/m"
    np.testing.assert_allclose(pset.values, theta, rtol=1e-9, atol=1e-12 * np.abs(theta).max())
    np.testing.assert_allclose(
        pset.covariance, result.covariance[: m.n_params, : m.n_params], rtol=0, atol=0
    )


def test_noise_free_84_coefficient_round_trip(samba_setup):
    m = Machine.load("five-axis-wcbxfzyst", "84")
    rng = np.random.default_rng(8)
    cands = [(b, c) for b in range(-90, 91, 15) for c in range(0, 360, 15) if (b, c) != (0, 0)]
    pairs = sorted([(0, 0)] + [cands[i] for i in rng.choice(len(cands), 30, replace=False)])
    theta = true_errors(m, rng, magnitude=5.0)
    problem = simulate(m, samba_setup, pairs, theta, backlash=True)
    result = levenberg_marquardt(problem)
    assert result.success
    # predictions, not coefficients, are the meaningful scale for 84 polynomial terms
    pred_true = m.forward(problem.readings, theta, senses=problem.senses)
    pred_est = m.forward(problem.readings, result.estimate[:84], senses=problem.senses)
    assert np.abs(pred_true - pred_est).max() < 1e-9


@pytest.mark.slow
def test_parameter_scatter_matches_the_propagated_covariance(samba_setup):
    """Digest 004 §5.2: with Gaussian noise σ on the indications, the empirical scatter of
    the estimates matches sqrt(diag((JᵀJ)⁻¹)). 200 repetitions: the ratio of standard
    deviations has a relative standard error of about 1/sqrt(2·199) = 5 %, so ±20 %."""
    m = Machine.load("five-axis-wcbxfzyst")
    rng = np.random.default_rng(42)
    theta = true_errors(m, rng)
    sigma = 0.001
    estimates = []
    for _ in range(200):
        problem = simulate(m, samba_setup, GRID_PAIRS, theta, noise=sigma, rng=rng)
        estimates.append(levenberg_marquardt(problem).estimate[: m.n_params])
    problem = simulate(m, samba_setup, GRID_PAIRS, theta)
    predicted = levenberg_marquardt(problem).standard_uncertainty[: m.n_params]
    ratio = np.std(estimates, axis=0, ddof=1) / predicted
    assert np.all(np.abs(ratio - 1.0) < 0.2), ratio
    # the unbiasedness of the estimator: mean within 4 standard errors
    err = (np.mean(estimates, axis=0) - theta) / (predicted / np.sqrt(200))
    assert np.all(np.abs(err) < 4.0)


def test_rank_deficient_identification_names_the_confounded_parameters(samba_setup):
    m = Machine.load("five-axis-wcbxfzyst")
    m = m.with_parameters([*m.parameter_names, "E_Y0C"])
    problem = simulate(m, samba_setup, GRID_PAIRS, np.zeros(m.n_params))
    with pytest.raises(IdentificationError, match="E_Y0S ~ E_Y0C"):
        levenberg_marquardt(problem)
