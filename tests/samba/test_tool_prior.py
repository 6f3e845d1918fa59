"""A prior on the tool vector (Alami Mchichi (2018) §5.3.4: the tool length known to
u = 1 mm) in the SAMBA identification and its uncertainty: the linear-Gaussian combination
of data and prior, a vague prior changing nothing, and the Monte Carlo validating the GUF.

The simulated test is the virtual one of the conftest (111 indications, 0.5 µm noise, the
tool estimated); its data alone give the tool to u_data ≈ (0.19, 0.19, 0.07) µm."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.identification import (
    identification_guf,
    identification_mcm,
    unknowns_covariance,
    validate_identification,
)
from mtmetrology.samba import calibrate, indication_inputs, uncertainty_model

from .samba_helpers import NOISE


def _with_prior(cal, prior):
    return calibrate(
        cal.machine, cal.records, cal.artefact, sigma=NOISE, estimate_tool=True, tool_prior=prior
    )


def _tool_covariance(cal):
    """GUF covariance (3, 3) of the tool vector, mm², inputs = readings, bar, prior."""
    return unknowns_covariance(
        cal.problem, cal.identification, indication_inputs(cal.problem, noise=NOISE)
    )[-3:, -3:]


@pytest.fixture(scope="module")
def data_only(noisy_calibration):
    """(tool estimate, its GUF covariance) from the data alone."""
    return noisy_calibration.tool, _tool_covariance(noisy_calibration)


def test_prior_on_one_component_combines_as_inverse_variances(noisy_calibration, data_only):
    """Prior on tool z only (x, y vague): 1/u² = 1/u_data² + 1/u_prior² for the GUF u of
    tool z, and the estimate moves towards t0 by the weight of the data,
    t − t0 = (u²/u_data²)(t_data − t0) — the exact linear-Gaussian combination.  Tolerance
    1e-4: the GUF differs from (JᵀJ)⁻¹ by the departure of the axis Jacobian from a
    rotation (scale gains of ~1e-5), and the model from linear by µm over metres."""
    t_data, cov_data = data_only
    u_data = np.sqrt(cov_data[2, 2])
    u_prior = 0.5 * u_data
    cal = _with_prior(noisy_calibration, (1e6, 1e6, u_prior))
    u_post = np.sqrt(_tool_covariance(cal)[2, 2])
    np.testing.assert_allclose(1 / u_post**2, 1 / u_data**2 + 1 / u_prior**2, rtol=1e-4)
    t0 = cal.machine.tool[2]
    expected = t0 + (u_post**2 / u_data**2) * (t_data[2] - t0)
    assert abs(cal.tool[2] - expected) < 1e-3 * u_post
    assert abs(cal.tool[2] - t0) < abs(t_data[2] - t0)


def test_prior_on_the_vector_adds_its_information(noisy_calibration, data_only):
    """Prior on all three components (u = u_data of each): the tool block of the GUF
    information is the data's plus diag(1/u_t²), and the estimate is the information-
    weighted mean of data and prior, t − t0 = U U_data⁻¹ (t_data − t0); the result
    records the prior."""
    t_data, cov_data = data_only
    u_prior = np.sqrt(np.diag(cov_data))
    cal = _with_prior(noisy_calibration, u_prior)
    cov = _tool_covariance(cal)
    info = np.linalg.inv(cov_data) + np.diag(1 / u_prior**2)
    scale = np.max(np.abs(info))
    np.testing.assert_allclose(np.linalg.inv(cov), info, rtol=0, atol=1e-4 * scale)
    t0 = cal.machine.tool
    expected = t0 + cov @ np.linalg.solve(cov_data, t_data - t0)
    u_post = np.sqrt(np.diag(cov))
    assert np.all(np.abs(cal.tool - expected) < 1e-3 * u_post)
    assert np.all(np.abs(cal.tool - t0) < np.abs(t_data - t0))
    doc = cal.to_dict()
    assert [p["name"] for p in doc["priors"]] == ["tool x", "tool y", "tool z"]
    np.testing.assert_array_equal([p["u"] for p in doc["priors"]], u_prior)
    np.testing.assert_array_equal([p["value"] for p in doc["priors"]], t0)
    assert noisy_calibration.to_dict()["priors"] == []


def test_vague_prior_changes_nothing(noisy_calibration):
    """u_t = 10 m: estimates and GUF uncertainties as without the prior to 1e-6 (its
    weight relative to the data's is (0.2 µm / 10 m)² ≈ 4e-16)."""
    cal = _with_prior(noisy_calibration, 1e4)
    x0 = noisy_calibration.identification.estimate
    u0 = np.sqrt(np.diag(noisy_calibration.identification.covariance))
    assert np.all(np.abs(cal.identification.estimate - x0) < 1e-6 * u0)
    g0 = identification_guf(
        uncertainty_model(noisy_calibration),
        indication_inputs(noisy_calibration.problem, noise=NOISE),
    )
    g = identification_guf(uncertainty_model(cal), indication_inputs(cal.problem, noise=NOISE))
    np.testing.assert_allclose(g.standard_uncertainty, g0.standard_uncertainty, rtol=1e-6)
    np.testing.assert_allclose(
        _tool_covariance(cal), _tool_covariance(noisy_calibration), rtol=1e-6
    )


def test_monte_carlo_with_the_prior_validates_the_guf(noisy_calibration, data_only):
    """The prior's value drawn in every trial: JCGM 102 §8 validation of the GUF by a
    Monte Carlo of 2·10⁴ trials (δ from one significant digit of u), with a prior tight
    enough (u_t = u_data/2) to shrink the u of the parameters it correlates with."""
    _, cov_data = data_only
    cal = _with_prior(noisy_calibration, 0.5 * np.sqrt(np.diag(cov_data)))
    inputs = indication_inputs(cal.problem, noise=NOISE)
    g = identification_guf(uncertainty_model(cal), inputs)
    g0 = identification_guf(
        uncertainty_model(noisy_calibration),
        indication_inputs(noisy_calibration.problem, noise=NOISE),
    )
    assert np.min(g.standard_uncertainty / g0.standard_uncertainty) < 0.9
    mc = identification_mcm(uncertainty_model(cal), inputs, trials=20_000, seed=7)
    report = validate_identification(g, mc, digits=1)
    assert report.passed
