"""The indication uncertainty of a SAMBA test (probing noise, repeatability model, K
campaigns) through the identification engine's GUF; the GUF, Monte Carlo and validation
themselves are tested in tests/identification/test_identification_uncertainty.py."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from mtmetrology.identification import identification_guf
from mtmetrology.samba import calibrate, indication_inputs, uncertainty_model
from mtmetrology.samba.uncertainty import pooled_sigma

from .samba_helpers import NOISE, simulate


@pytest.fixture(scope="module")
def exact_calibration(tmp_path_factory, machine13, truth13, balls, programme, artefact):
    """Noise-free records: the estimate is the truth, J is the Jacobian at the truth."""
    rec = simulate(tmp_path_factory.mktemp("exact"), machine13, truth13, balls, programme, artefact)
    return calibrate(machine13, rec, artefact, sigma=NOISE, estimate_tool=True)


@pytest.fixture(scope="module")
def noise_inputs(noisy_calibration):
    return indication_inputs(noisy_calibration.problem, noise=NOISE)


def _guf(cal, inputs):
    return identification_guf(uncertainty_model(cal), inputs)


def test_k_campaigns_give_a_covariance_consistent_with_the_simulated_noise(
    tmp_path, machine13, truth13, balls, programme, artefact, exact_calibration
):
    """K = 20 campaigns: the pooled variance has (K−1)·3n degrees of freedom,
    (K−1)·3n·σ̄²/σ² ~ χ²; each parameter's GUF variance from the sample covariance S/K
    follows (K−1)·u²/u²_true ~ χ²_{K−1} (tests at level 0.001, Bonferroni over 13)."""
    k = 20
    rec = simulate(
        tmp_path, machine13, truth13, balls, programme, artefact, noise=NOISE, campaigns=k, seed=4
    )
    assert rec.campaigns.shape == (k, len(rec), 3)
    sigma = pooled_sigma(rec.campaigns)
    dof = (k - 1) * rec.campaigns[0].size
    stat = dof * sigma**2 / NOISE**2
    assert stats.chi2.ppf(0.0005, dof) < stat < stats.chi2.ppf(0.9995, dof)
    cal = calibrate(machine13, rec, artefact, sigma=sigma, estimate_tool=True)
    g = _guf(cal, indication_inputs(cal.problem, campaigns=rec.campaigns))
    g_true = _guf(
        exact_calibration, indication_inputs(exact_calibration.problem, noise=NOISE / np.sqrt(k))
    )
    ratio = (k - 1) * g.standard_uncertainty**2 / g_true.standard_uncertainty**2
    level = 0.001 / 13
    assert np.all(ratio > stats.chi2.ppf(level / 2, k - 1))
    assert np.all(ratio < stats.chi2.ppf(1 - level / 2, k - 1))


def test_a_repeatability_model_of_equal_axes_is_the_probing_noise(noisy_calibration, noise_inputs):
    same = indication_inputs(noisy_calibration.problem, repeatability=(NOISE, NOISE, NOISE))
    np.testing.assert_array_equal(same.covariance, noise_inputs.covariance)
    doubled = indication_inputs(
        noisy_calibration.problem, repeatability=(2 * NOISE, 2 * NOISE, 2 * NOISE)
    )
    g1 = _guf(noisy_calibration, noise_inputs)
    g2 = _guf(noisy_calibration, doubled)
    # the bar's u does not double: every u grows, by at most a factor 2
    assert np.all(g2.standard_uncertainty > g1.standard_uncertainty)
    assert np.all(g2.standard_uncertainty <= 2 * g1.standard_uncertainty * (1 + 1e-12))
