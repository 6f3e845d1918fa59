"""Uncertainty of an identification (mtmetrology.identification.uncertainty): GUF through
the full Jacobian, Monte Carlo re-solving every trial, their JCGM 102 validation, coverage
over many simulated campaigns, the coverage factors of the sources, and the generic API on
an observation model with an exact solution."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from threadpoolctl import threadpool_info, threadpool_limits

from mtmetrology.errors import InputError
from mtmetrology.identification import (
    IdentificationModel,
    identification_guf,
    identification_mcm,
    joint_coverage,
    levenberg_marquardt,
    unknowns_covariance,
    validate_identification,
)
from mtmetrology.samba import indication_inputs, simulate_records, uncertainty_model
from mtmetrology.uncertainty import InputQuantity, InputSet, Normal
from mtmetrology.uncertainty.regions import normal_rectangular_coverage_factor
from mtmetrology.units import to_internal

NOISE = float(to_internal(0.5, "µm"))  # probing noise of the virtual test (conftest), mm


@pytest.fixture(scope="module")
def noisy(virtual_samba):
    return virtual_samba.calibration(noise=NOISE, seed=11)


@pytest.fixture(scope="module")
def exact(virtual_samba):
    """Noise-free records: the estimate is the truth, J is the Jacobian at the truth."""
    return virtual_samba.calibration()


@pytest.fixture(scope="module")
def noise_inputs(noisy):
    return indication_inputs(noisy.problem, noise=NOISE)


def test_guf_with_probing_noise_is_the_inverse_normal_matrix(noisy, noise_inputs):
    """U_z = σ² I: C U_z Cᵀ = (JᵀJ)⁻¹ of the weighted problem, up to the departure of the
    axis Jacobian from a rotation (the scale gains, ~1e-4)."""
    g = identification_guf(uncertainty_model(noisy), noise_inputs)
    cal_u = noisy.parameters.standard_uncertainty / noisy.machine.parameter_scales
    np.testing.assert_allclose(g.standard_uncertainty, cal_u, rtol=1e-3)
    assert g.names == noisy.machine.parameter_names
    assert g.units[2] == "µm" and g.units[0] == "µrad" and g.units[8] == "µm/m"


def test_chord_trials_are_the_full_levenberg_marquardt_solutions(noisy, noise_inputs):
    """Every Monte Carlo trial re-solves to convergence: the batched chord solution equals
    full Gauss–Newton with the exact Jacobian of the perturbed problem.  The chord's fixed
    point solves J₀ᵀr = 0 instead of J(x)ᵀr = 0; the difference is second order in the
    perturbation, here below 1 % of each standard uncertainty — against a Monte Carlo
    standard error of u/√(2M), 0.2 % at M = 10⁵, and of random sign."""
    model = uncertainty_model(noisy)
    z = noise_inputs.sample(np.random.default_rng(3), 3)
    batched = model.solve(z)
    u = np.sqrt(np.diag(noisy.identification.covariance))
    for k in range(3):
        exact_solution = model._full_solve(z[k])
        assert np.all(np.abs(batched[k] - exact_solution) < 1e-2 * u)


def test_trials_start_at_the_linear_prediction_and_need_one_exact_evaluation(noisy, noise_inputs):
    """The start x̂ + C (z − z₀) only saves chord iterations: the trials reach the same
    fixed point as from x̂ (within ρ·xtol·u, here 1e-6 u), after one residual evaluation
    instead of two."""
    model = uncertainty_model(noisy)
    z = noise_inputs.sample(np.random.default_rng(5), 200)
    calls = []
    original = model.problem.residuals_batch

    def counted(x, inputs=None):
        calls.append(x.shape[0])
        return original(x, inputs)

    model.problem.residuals_batch = counted
    try:
        predicted = model.solve(z)
        n_predicted = len(calls)
        model.z0, z0 = None, model.z0  # the solution as the start of every trial
        from_solution = model.solve(z)
    finally:
        model.z0 = z0
        del model.problem.residuals_batch
    assert n_predicted == 1 and len(calls) == 3
    u = np.sqrt(np.diag(noisy.identification.covariance))
    assert np.all(np.abs(predicted - from_solution) < 1e-6 * u)


def test_adaptive_monte_carlo_validates_the_guf_per_parameter_and_jointly(noisy, noise_inputs):
    """JCGM 101 §7.9 adaptive run (δ from one significant digit of u: 0.05 µrad, 0.05 µm,
    0.5 µm/m — Sepahi Boroujeni (2021) Table 5-2's tolerances) and JCGM 102 §8 validation."""
    model = uncertainty_model(noisy)
    g = identification_guf(model, noise_inputs)
    mc = identification_mcm(
        model, noise_inputs, adaptive=True, digits=1, seed=5, sequence_size=4000
    )
    assert mc.converged and mc.trials % 4000 == 0
    report = validate_identification(g, mc, digits=1)
    quantities = {(r.name, r.quantity) for r in report.rows}
    assert len(report.rows) == 2 * 13 + 2
    assert ("all", "coverage factor") in quantities and ("all", "largest eigenvalue") in quantities
    assert report.passed, report.message
    assert abs(mc.region_coverage_factor - joint_coverage(13)["hyper_ellipsoid"]) < 0.05


def test_same_numbers_for_a_seed_on_any_executor(noisy, noise_inputs):
    """Every trial bit for bit, in-process (the caller at 2 BLAS threads) and on 1 or 2
    worker processes (pinned to 1): chunk streams depend on the seed and chunk index only."""
    model = uncertainty_model(noisy)
    options = {"trials": 4000, "seed": 9, "chunk_size": 700, "keep_samples": True}
    with threadpool_limits(2):
        one = identification_mcm(model, noise_inputs, **options)
    for executor in ("processes:1", "processes:2"):
        pool = identification_mcm(model, noise_inputs, executor=executor, **options)
        np.testing.assert_array_equal(one.samples, pool.samples)
        np.testing.assert_array_equal(one.estimate, pool.estimate)
        np.testing.assert_array_equal(one.covariance, pool.covariance)


def test_trials_are_solved_at_one_blas_thread_and_the_caller_keeps_its_own(
    noisy, noise_inputs, monkeypatch
):
    """A chunk's matrices are too small for BLAS threads (module notes of
    identification.uncertainty): the model limits them while it solves, then restores."""
    model = uncertainty_model(noisy)
    seen = []
    residuals = model.problem.residuals_batch

    def recording(x, z):
        seen.append({p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"})
        return residuals(x, z)

    monkeypatch.setattr(model.problem, "residuals_batch", recording)
    with threadpool_limits(2):
        model(noise_inputs.sample(np.random.default_rng(3), 50))
        after = {p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"}
    assert seen and all(s == {1} for s in seen)
    assert after == {2}


@pytest.mark.parametrize("workflow", ["identification_mcm", "identification_guf"])
def test_statistics_run_at_one_blas_thread(noisy, noise_inputs, monkeypatch, workflow):
    """The serial part (eigh of the output covariance, products of the samples; C U Cᵀ)
    runs at one BLAS thread too: on a busy 2-core machine multi-threaded LAPACK took 0.35 s
    for the 84 × 84 eigh of the 84-parameter model."""
    from mtmetrology.identification import uncertainty as module

    seen = []

    def recording(*args, **kwargs):
        seen.append({p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"})

    monkeypatch.setattr(module, "monte_carlo", recording)
    monkeypatch.setattr(module, "guf_propagate", recording)
    with threadpool_limits(2):
        getattr(module, workflow)(uncertainty_model(noisy), noise_inputs)
    assert seen == [{1}]


def _campaign_readings(records, n_campaigns):
    """Linear readings (K, 3n) of each simulated campaign (rows campaign,ball,X,Y,Z,...)."""
    table = np.array([[float(v) for v in row[2:5]] for row in records.rows])
    return table.reshape(n_campaigns, -1)


def test_95_percent_intervals_cover_the_truth_over_many_simulated_campaigns(exact, virtual_samba):
    """R = 400 simulated campaigns (noise 0.5 µm), each re-identified to convergence.

    Binomial tests at level 0.001: the number of campaigns whose 13 errors lie in the GUF
    95 % hyper-ellipsoid (k_p = sqrt(χ²_13(0.95))), and, per parameter (Bonferroni, level
    0.001/13), the number whose ±1.96u interval covers the truth, are consistent with
    Binomial(400, 0.95).  Each campaign also draws the error of the bar's certificate
    (u = 1 µm), which the GUF includes."""
    v, runs = virtual_samba, 400
    records = simulate_records(
        v.machine,
        v.truth,
        v.balls,
        v.programme,
        v.artefact,
        noise=NOISE,
        campaigns=runs,
        seed=21,
    )
    bar = v.artefact.scale_bar
    lengths = bar.length_mm + bar.u_mm * np.random.default_rng(22).standard_normal((runs, 1))
    z = np.hstack([_campaign_readings(records, runs), lengths])
    model = uncertainty_model(exact)
    estimates = model(z)  # customary units
    g = identification_guf(model, indication_inputs(exact.problem, noise=NOISE))
    dev = estimates - v.truth / v.machine.parameter_scales
    d2 = np.einsum("ri,ij,rj->r", dev, np.linalg.inv(g.covariance), dev)
    inside = int(np.sum(d2 <= g.region_coverage_factor**2))
    assert stats.binomtest(inside, runs, 0.95).pvalue > 0.001, inside
    covered = np.sum(np.abs(dev) <= 1.96 * g.standard_uncertainty, axis=0)
    pvalues = [stats.binomtest(int(c), runs, 0.95).pvalue for c in covered]
    assert min(pvalues) > 0.001 / 13, covered


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


# -- the generic API on an observation model that is not SAMBA -------------------------------
class StraightLine:
    """Observation model y_i = a + b t_i with readings y (the inputs z), weights 1/σ:
    linear, so the GUF covariance is exactly σ²(AᵀA)⁻¹ and every Monte Carlo trial is the
    exact least-squares solution."""

    names = ("a", "b")

    def __init__(self, t, y, sigma):
        self.t, self.y, self.sigma = np.asarray(t, float), np.asarray(y, float), float(sigma)
        self.n_rows = self.t.size

    def evaluate(self, x, jacobian=True):
        r = (x[0] + x[1] * self.t - self.y) / self.sigma
        return r, np.column_stack([np.ones_like(self.t), self.t]) / self.sigma

    def initial(self):
        return np.zeros(2)

    def input_jacobian(self, x):
        return -np.eye(self.n_rows) / self.sigma

    def residuals_batch(self, x, inputs):
        return (x[:, :1] + x[:, 1:] * self.t - inputs) / self.sigma

    def with_inputs(self, z):
        return StraightLine(self.t, z, self.sigma)


@pytest.fixture(scope="module")
def line():
    t = np.linspace(-1.0, 1.0, 9)
    y = 0.3 + 2.0 * t + 0.01 * np.random.default_rng(1).standard_normal(t.size)
    problem = StraightLine(t, y, 0.01)
    inputs = InputSet(
        [InputQuantity(f"y{i}", Normal(v, 0.01), "mm") for i, v in enumerate(problem.y)]
    )
    return problem, levenberg_marquardt(problem), inputs


def test_any_observation_model_gets_the_exact_linear_covariance(line):
    problem, result, inputs = line
    a = np.column_stack([np.ones_like(problem.t), problem.t])
    expected = 0.01**2 * np.linalg.inv(a.T @ a)
    np.testing.assert_allclose(
        unknowns_covariance(problem, result, inputs), expected, rtol=1e-10, atol=1e-18
    )
    g = identification_guf(IdentificationModel(problem, result, outputs=["b"]), inputs)
    assert g.names == ("b",)
    np.testing.assert_allclose(g.standard_uncertainty, [np.sqrt(expected[1, 1])], rtol=1e-10)


def test_monte_carlo_of_a_linear_identification_matches_its_guf(line):
    """Linear model, normal inputs: the Monte Carlo covariance is that of the GUF up to
    sampling (10⁴ trials: relative standard error of a variance √(2/M) = 1.4 %; bound 5 of
    them, exceeded with probability below 1e-6)."""
    problem, result, inputs = line
    model = IdentificationModel(problem, result)
    g = identification_guf(model, inputs)
    mc = identification_mcm(model, inputs, trials=10_000, seed=3)
    np.testing.assert_allclose(np.diag(mc.covariance), np.diag(g.covariance), rtol=5 * 0.0142)
    # the mean's standard error is u/√M = u/100
    assert np.all(np.abs(mc.estimate - g.estimate) < 5 * g.standard_uncertainty / 100)


def test_an_output_that_is_not_an_unknown_is_an_input_error(line):
    problem, result, _ = line
    with pytest.raises(InputError, match="'c' is not an unknown"):
        IdentificationModel(problem, result, outputs=["a", "c"])
