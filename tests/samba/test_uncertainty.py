"""Uncertainty through the SAMBA identification: GUF through the full Jacobian, Monte
Carlo re-solving every trial, their JCGM 102 validation, coverage over many simulated
campaigns, and the coverage factors of the sources."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from mtmetrology.samba import (
    IdentificationModel,
    calibrate,
    identification_guf,
    identification_mcm,
    indication_inputs,
    joint_coverage,
    simulate_records,
)
from mtmetrology.samba.uncertainty import pooled_sigma, validate
from mtmetrology.uncertainty.regions import normal_rectangular_coverage_factor

from .samba_helpers import NOISE, simulate


@pytest.fixture(scope="module")
def exact_calibration(tmp_path_factory, machine13, truth13, balls, programme, artefact):
    """Noise-free records: the estimate is the truth, J is the Jacobian at the truth."""
    rec = simulate(tmp_path_factory.mktemp("exact"), machine13, truth13, balls, programme, artefact)
    return calibrate(machine13, rec, artefact, sigma=NOISE, estimate_tool=True)


@pytest.fixture(scope="module")
def noise_inputs(noisy_calibration):
    return indication_inputs(noisy_calibration.problem, noise=NOISE)


def test_guf_with_probing_noise_is_the_inverse_normal_matrix(noisy_calibration, noise_inputs):
    """U_z = σ² I: C U_z Cᵀ = (JᵀJ)⁻¹ of the weighted problem, up to the departure of the
    axis Jacobian from a rotation (the scale gains, ~1e-4)."""
    g = identification_guf(noisy_calibration, noise_inputs)
    cal_u = (
        noisy_calibration.parameters.standard_uncertainty
        / noisy_calibration.machine.parameter_scales
    )
    np.testing.assert_allclose(g.standard_uncertainty, cal_u, rtol=1e-3)
    assert g.names == noisy_calibration.machine.parameter_names
    assert g.units[2] == "µm" and g.units[0] == "µrad" and g.units[8] == "µm/m"


def test_chord_trials_are_the_full_gauss_newton_solutions(noisy_calibration, noise_inputs):
    """Every Monte Carlo trial re-solves to convergence: the batched chord solution equals
    full Gauss–Newton with the exact Jacobian of the perturbed problem.  The chord's fixed
    point solves J₀ᵀr = 0 instead of J(x)ᵀr = 0; the difference is second order in the
    perturbation (the product of the noise and the change of the Jacobian it causes),
    here below 1 % of each standard uncertainty — against a Monte Carlo standard error of
    u/√(2M), 0.2 % at M = 10⁵, and of random sign."""
    model = IdentificationModel(noisy_calibration)
    z = noise_inputs.sample(np.random.default_rng(3), 3)
    batched = model.solve(z)
    u = np.sqrt(np.diag(noisy_calibration.identification.covariance))
    for k in range(3):
        exact = model._full_solve(z[k])
        assert np.all(np.abs(batched[k] - exact) < 1e-2 * u)


def test_adaptive_monte_carlo_validates_the_guf_per_parameter_and_jointly(
    noisy_calibration, noise_inputs
):
    """JCGM 101 §7.9 adaptive run (δ from one significant digit of u: 0.05 µrad, 0.05 µm,
    0.5 µm/m — Sepahi Boroujeni (2021) Table 5-2's tolerances) and JCGM 102 §8 validation."""
    g = identification_guf(noisy_calibration, noise_inputs)
    mc = identification_mcm(
        noisy_calibration, noise_inputs, adaptive=True, digits=1, seed=5, sequence_size=4000
    )
    assert mc.converged and mc.trials % 4000 == 0
    report = validate(g, mc, digits=1)
    quantities = {(r.name, r.quantity) for r in report.rows}
    assert len(report.rows) == 2 * 13 + 2
    assert ("all", "coverage factor") in quantities and ("all", "largest eigenvalue") in quantities
    assert report.passed, report.message
    assert abs(mc.region_coverage_factor - joint_coverage(13)["hyper_ellipsoid"]) < 0.05


def test_same_numbers_for_a_seed_on_any_executor(noisy_calibration, noise_inputs):
    one = identification_mcm(noisy_calibration, noise_inputs, trials=4000, seed=9)
    pool = identification_mcm(
        noisy_calibration, noise_inputs, trials=4000, seed=9, executor="processes:2"
    )
    np.testing.assert_array_equal(one.estimate, pool.estimate)
    np.testing.assert_array_equal(one.covariance, pool.covariance)


def _campaign_readings(records, n_campaigns):
    """Linear readings (K, 3n) of each simulated campaign (rows campaign,ball,X,Y,Z,...)."""
    table = np.array([[float(v) for v in row[2:5]] for row in records.rows])
    return table.reshape(n_campaigns, -1)


def test_95_percent_intervals_cover_the_truth_over_many_simulated_campaigns(
    exact_calibration, machine13, truth13, balls, programme, artefact
):
    """R = 400 simulated campaigns (noise 0.5 µm), each re-identified to convergence.

    Binomial tests at level 0.001: the number of campaigns whose 13 errors lie in the GUF
    95 % hyper-ellipsoid (k_p = sqrt(χ²_13(0.95))), and, per parameter (Bonferroni, level
    0.001/13), the number whose ±1.96u interval covers the truth, are consistent with
    Binomial(400, 0.95).  Each campaign also draws the error of the bar's certificate
    (u = 1 µm), which the GUF includes."""
    runs = 400
    records = simulate_records(
        machine13, truth13, balls, programme, artefact, noise=NOISE, campaigns=runs, seed=21
    )
    bar = artefact.scale_bar
    lengths = bar.length_mm + bar.u_mm * np.random.default_rng(22).standard_normal((runs, 1))
    z = np.hstack([_campaign_readings(records, runs), lengths])
    model = IdentificationModel(exact_calibration)
    estimates = model(z)  # customary units
    g = identification_guf(
        exact_calibration, indication_inputs(exact_calibration.problem, noise=NOISE)
    )
    truth = truth13 / machine13.parameter_scales
    dev = estimates - truth
    d2 = np.einsum("ri,ij,rj->r", dev, np.linalg.inv(g.covariance), dev)
    inside = int(np.sum(d2 <= g.region_coverage_factor**2))
    assert stats.binomtest(inside, runs, 0.95).pvalue > 0.001, inside
    covered = np.sum(np.abs(dev) <= 1.96 * g.standard_uncertainty, axis=0)
    pvalues = [stats.binomtest(int(c), runs, 0.95).pvalue for c in covered]
    assert min(pvalues) > 0.001 / 13, covered


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
    g = identification_guf(cal, indication_inputs(cal.problem, campaigns=rec.campaigns))
    g_true = identification_guf(
        exact_calibration, indication_inputs(exact_calibration.problem, noise=NOISE / np.sqrt(k))
    )
    ratio = (k - 1) * g.standard_uncertainty**2 / g_true.standard_uncertainty**2
    level = 0.001 / 13
    assert np.all(ratio > stats.chi2.ppf(level / 2, k - 1))
    assert np.all(ratio < stats.chi2.ppf(1 - level / 2, k - 1))


def test_thesis_k_q_is_a_bonferroni_factor_over_all_unknowns_not_sqrt_chi2_m():
    """Alami Mchichi (2018) eq. 5.18 gives k_q = 3.12-3.15 for the 13-parameter model and
    3.49 for the 84; sqrt(χ²_13(0.95)) is 4.73 (Sepahi Boroujeni (2021) Table 5-3). The
    thesis values are the Bonferroni hyper-rectangle factors Φ⁻¹(1 − 0.05/2n) over all n
    unknowns: n = 28 (13 + 4 balls + tool) to 31 (13 + 6 balls), and n = 105."""
    assert round(joint_coverage(13)["hyper_ellipsoid"], 2) == 4.73
    assert round(normal_rectangular_coverage_factor(28), 2) == 3.12
    assert round(normal_rectangular_coverage_factor(31), 2) == 3.15
    assert round(normal_rectangular_coverage_factor(105), 2) == 3.49
    assert abs(joint_coverage(13)["hyper_ellipsoid"] - 3.12) > 1.5


def test_a_repeatability_model_of_equal_axes_is_the_probing_noise(noisy_calibration, noise_inputs):
    same = indication_inputs(noisy_calibration.problem, repeatability=(NOISE, NOISE, NOISE))
    np.testing.assert_array_equal(same.covariance, noise_inputs.covariance)
    doubled = indication_inputs(
        noisy_calibration.problem, repeatability=(2 * NOISE, 2 * NOISE, 2 * NOISE)
    )
    g1 = identification_guf(noisy_calibration, noise_inputs)
    g2 = identification_guf(noisy_calibration, doubled)
    # the bar's u does not double: every u grows, by at most a factor 2
    assert np.all(g2.standard_uncertainty > g1.standard_uncertainty)
    assert np.all(g2.standard_uncertainty <= 2 * g1.standard_uncertainty * (1 + 1e-12))
