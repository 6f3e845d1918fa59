"""Monte Carlo propagation, fixed and adaptive (JCGM 101 §7, JCGM 102 §7)."""

import numpy as np
import pytest
from scipy import stats

from mtmetrology.uncertainty.distributions import Rectangular
from mtmetrology.uncertainty.inputs import InputQuantity, InputSet
from mtmetrology.uncertainty.mcm import (
    ModelEvaluationError,
    NumericalTolerance,
    monte_carlo,
)
from mtmetrology.uncertainty.regions import coverage_intervals


def normal_inputs(mean, std):
    """Independent normal inputs x0, x1, ... as an InputSet (picklable for workers)."""
    std = np.asarray(std, dtype=float)
    return InputSet.from_covariance([f"x{i}" for i in range(std.size)], mean, np.diag(std**2))


RECTANGULAR_PAIR = InputSet([InputQuantity(n, Rectangular(-1.0, 1.0)) for n in ("x0", "x1")])


def total(x):
    return x.sum(axis=1)


SUM_INPUTS = normal_inputs([1.0, 2.0, -1.0], [0.1, 0.2, 0.3])
SUM_U = np.sqrt(0.1**2 + 0.2**2 + 0.3**2)  # 0.374166


def test_sum_of_normals_is_exact_within_mcm_noise():
    """Y = X1 + X2 + X3 of normals: y = 2, u = 0.3742, interval y ± 1.96 u. With M = 2·10⁵
    the mean has standard deviation u/√M = 0.0008 and u a relative one of 1/√(2M) = 0.16 %;
    the tolerances are 5σ."""
    result = monte_carlo(total, SUM_INPUTS, trials=200_000, seed=11)
    summary = result.output()
    assert summary.value == pytest.approx(2.0, abs=0.004)
    assert summary.u == pytest.approx(SUM_U, rel=0.008)
    np.testing.assert_allclose(summary.interval, 2.0 + np.array([-1.96, 1.96]) * SUM_U, atol=0.01)
    assert summary.k == pytest.approx(1.96, abs=0.02)
    assert summary.U == pytest.approx(summary.k * summary.u, rel=1e-12)
    assert result.trials == 200_000 and result.sequences == 1 and result.converged is None
    assert result.largest_eigenvalue == 1.0 and result.scalar_model
    # One output: the region is the interval, no multivariate factors are computed.
    assert result.region_coverage_factor is None and result.rectangular_coverage_factor is None
    assert result.m == 1 and result.interval_shortest.shape == (1, 2)
    assert result.names == ("y",) and result.units == ("",)


def test_sum_of_two_equal_rectangulars_is_triangular():
    """R(−1, 1) + R(−1, 1) is triangular on [−2, 2]: P(Y ≤ −a) = (2 − a)²/8 = 0.025 gives
    the 95 % interval ±(2 − √0.2) = ±1.5528 (probabilistically symmetric and shortest).
    At M = 4·10⁵ each end has a standard deviation of 0.0022; tolerance 0.01."""
    result = monte_carlo(total, RECTANGULAR_PAIR, trials=400_000, seed=12)
    exact = np.array([-1.0, 1.0]) * (2.0 - np.sqrt(0.2))
    np.testing.assert_allclose(result.interval[0], exact, atol=0.01)
    np.testing.assert_allclose(result.interval_shortest[0], exact, atol=0.015)
    assert result.output().u == pytest.approx(np.sqrt(2 / 3), rel=0.005)
    density = result.histogram(0)
    assert np.max(density.values) == pytest.approx(0.5, rel=0.05)  # triangular peak 1/2


def test_linear_vector_model_matches_jcgm102_gaussian_results():
    """Y = A X, X ~ N(μ, U_x): U_y = A U_x Aᵀ exactly, k_p → sqrt(χ²_3(0.95)) = 2.7955
    (JCGM 102, 6.5.2.3), λ_max → the largest eigenvalue of the exact correlation matrix.
    M = 3·10⁵: covariance entries have relative standard deviations below 0.3 %, k_p 0.004."""
    a = np.array([[1.0, 2.0, 0.0], [0.5, -1.0, 1.0], [0.0, 1.0, 3.0]])
    covariance_x = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, -0.02], [0.0, -0.02, 0.01]])
    inputs = InputSet.from_covariance(["x0", "x1", "x2"], [1.0, 2.0, 3.0], covariance_x)
    result = monte_carlo(lambda x: x @ a.T, inputs, trials=300_000, seed=13)
    exact = a @ covariance_x @ a.T
    u = np.sqrt(np.diag(exact))
    np.testing.assert_allclose(result.estimate, a @ [1.0, 2.0, 3.0], atol=4 * u.max() / 500)
    np.testing.assert_allclose(result.covariance, exact, atol=0.012 * u.max() ** 2)
    assert result.region_coverage_factor == pytest.approx(
        np.sqrt(stats.chi2.ppf(0.95, 3)), abs=0.02
    )
    lam = np.linalg.eigvalsh(exact / np.outer(u, u))[-1]
    assert result.largest_eigenvalue == pytest.approx(lam, abs=0.01)
    np.testing.assert_allclose(np.diag(result.correlation), 1.0)
    assert not result.scalar_model and result.names == ("y1", "y2", "y3")
    with pytest.raises(ValueError, match="out of range for 3 outputs"):
        result.output(3)


def test_adaptive_procedure_stops_and_meets_its_tolerances():
    """JCGM 101 7.9.4 with n_dig = 2: δ = 0.005 for u = 0.374; every reported spread
    2·s/√h is ≤ its δ; trials are whole sequences; the estimate is within 2δ of the exact
    2.0 (δ is about two standard deviations of the average, so 2δ is about 4σ)."""
    result = monte_carlo(total, SUM_INPUTS, adaptive=True, digits=2, seed=21)
    assert result.converged is True
    assert result.sequences >= 2 and result.trials == result.sequences * 10_000
    assert {c.quantity for c in result.checks} == {
        "estimate",
        "standard uncertainty",
        "interval low",
        "interval high",
    }
    assert all(c.spread <= c.tolerance for c in result.checks)
    np.testing.assert_allclose(result.tolerance.output, [0.005])
    assert abs(result.output().value - 2.0) <= 2 * 0.005
    assert abs(result.output().u - SUM_U) <= 2 * 0.005


def test_strict_criterion_stops_later():
    """s ≤ δ (Sepahi Boroujeni 2021, Ch. 5, starting at h₀ = 10) against 2·s/√h ≤ δ (JCGM):
    with n_dig = 1 (δ = 0.05) JCGM stops at the first test, h = 2; the strict rule needs h ≥ 10."""
    jcgm = monte_carlo(total, SUM_INPUTS, adaptive=True, digits=1, seed=22)
    strict = monte_carlo(total, SUM_INPUTS, adaptive=True, digits=1, seed=22, criterion="strict")
    assert jcgm.converged and strict.converged
    assert strict.trials > jcgm.trials
    assert strict.sequences >= 10
    assert strict.criterion == "strict" and jcgm.criterion == "jcgm"
    assert all(c.spread <= c.tolerance for c in strict.checks)


def test_adaptive_vector_model_checks_eigenvalue_and_coverage_factor():
    """JCGM 102 7.8 for m = 2: λ_max and k_p are tested too; ρ and κ_p from their own two
    significant digits (λ ≈ 1.6 -> 0.05, k_p ≈ 2.45 -> 0.05) unless given."""
    a = np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 1.0]])
    result = monte_carlo(lambda x: x @ a.T, SUM_INPUTS, adaptive=True, seed=23)
    quantities = [c.quantity for c in result.checks]
    assert quantities.count("largest eigenvalue") == 1 and quantities.count("coverage factor") == 1
    assert result.tolerance.eigenvalue == pytest.approx(0.05)
    assert result.tolerance.coverage_factor == pytest.approx(0.05)
    assert all(c.passed for c in result.checks)
    explicit = monte_carlo(
        lambda x: x @ a.T,
        SUM_INPUTS,
        adaptive=True,
        seed=23,
        tolerance=NumericalTolerance([0.004, 0.004], eigenvalue=0.02, coverage_factor=0.02),
    )
    # Same seed, same sequences, every tolerance tighter: the first h that passes can only
    # come later.
    assert explicit.tolerance.eigenvalue == 0.02
    assert explicit.converged and explicit.trials >= result.trials


def test_adaptive_run_without_convergence_says_so():
    tolerance = 1e-6  # would need ~10¹¹ trials
    result = monte_carlo(
        total, SUM_INPUTS, adaptive=True, tolerance=tolerance, max_trials=30_000, seed=24
    )
    assert result.converged is False
    assert result.trials == 30_000
    failing = {c.quantity for c in result.checks if not c.passed}
    assert "estimate" in failing


def test_adaptive_sequences_are_the_fixed_run_streams():
    """Sequence 0 of an adaptive run uses the same streams as a fixed run of M trials."""
    fixed = monte_carlo(total, SUM_INPUTS, trials=10_000, seed=25, keep_samples=True)
    adaptive = monte_carlo(total, SUM_INPUTS, adaptive=True, seed=25, keep_samples=True)
    np.testing.assert_array_equal(adaptive.samples[:10_000], fixed.samples)


def test_same_seed_same_result_and_chunking_bounds_calls():
    calls = []

    def counting(x):
        calls.append(x.shape[0])
        return x.sum(axis=1)

    first = monte_carlo(counting, SUM_INPUTS, trials=25_000, chunk_size=10_000, seed=26)
    assert calls == [10_000, 10_000, 5_000]
    second = monte_carlo(total, SUM_INPUTS, trials=25_000, chunk_size=10_000, seed=26)
    np.testing.assert_array_equal(first.estimate, second.estimate)
    np.testing.assert_array_equal(first.interval_shortest, second.interval_shortest)
    generator = monte_carlo(total, SUM_INPUTS, trials=5_000, seed=np.random.default_rng(3))
    again = monte_carlo(total, SUM_INPUTS, trials=5_000, seed=np.random.default_rng(3))
    np.testing.assert_array_equal(generator.estimate, again.estimate)


def test_coverage_of_the_mcm_interval_is_95_percent():
    """10 000 simulated measurements x_i ~ N(μ, σ) of a normal scalar model Y = X; each gets
    its own MCM of M = 1000 trials from N(x_i, σ), done as one (M, 10 000) array through
    the same interval code monte_carlo uses (coverage_intervals). The expected coverage is
    E[U_(975) − U_(25)] = 950/1001 = 0.949; the binomial standard deviation over 10 000
    repetitions is 0.0022, so 95 ± 1 % is a 4σ band."""
    rng = np.random.default_rng(31)
    mu, sigma, repetitions, trials = 10.0, 0.5, 10_000, 1_000
    measured = rng.normal(mu, sigma, repetitions)  # (R,)
    model_values = measured + sigma * rng.standard_normal((trials, repetitions))  # (M, R)
    symmetric, shortest = coverage_intervals(model_values, 0.95)  # (R, 2) each
    for interval in (symmetric, shortest):
        covered = np.mean((interval[:, 0] <= mu) & (mu <= interval[:, 1]))
        assert 0.94 <= covered <= 0.96
    # monte_carlo gives the same interval as coverage_intervals on its own samples.
    run = monte_carlo(
        total, normal_inputs([measured[0]], [sigma]), trials=1_000, seed=1, keep_samples=True
    )
    np.testing.assert_array_equal(run.interval, coverage_intervals(run.samples)[0])


def test_shortest_interval_of_an_asymmetric_output_is_strictly_shorter():
    """Y = X² with X ~ N(0, 1) (χ²_1): the shortest interval starts at 0, ≈ [0, 3.84]; the
    symmetric one is [χ²_1(0.025), χ²_1(0.975)] = [0.00098, 5.02]."""
    result = monte_carlo(
        lambda x: x[:, 0] ** 2, normal_inputs([0.0], [1.0]), trials=200_000, seed=32
    )
    low, high = result.interval_shortest[0]
    assert high - low < 0.8 * np.ptp(result.interval[0])
    assert low == pytest.approx(0.0, abs=1e-3)
    assert high == pytest.approx(stats.chi2.ppf(0.95, 1), abs=0.06)
    np.testing.assert_allclose(result.interval[0], stats.chi2.ppf([0.025, 0.975], 1), atol=0.08)


def test_samples_histograms_and_pairwise_areas():
    a = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    result = monte_carlo(lambda x: x @ a.T, SUM_INPUTS, trials=100_000, seed=33, keep_samples=True)
    assert result.samples.shape == (100_000, 2)
    assert not result.samples.flags.writeable
    areas = result.pairwise_areas(0, 1)
    assert areas.ellipse == pytest.approx(np.pi * stats.chi2.ppf(0.95, 2) * 0.1 * 0.2, rel=0.02)
    assert result.histogram(1, bins=20).values.shape == (20,)
    lean = monte_carlo(lambda x: x @ a.T, SUM_INPUTS, trials=10_000, seed=33)
    assert lean.samples is None
    assert lean.histogram(0).values.shape == (100,)
    with pytest.raises(ValueError, match="keep_samples"):
        lean.histogram(0, bins=10)
    with pytest.raises(ValueError, match="keep_samples"):
        lean.pairwise_areas(0, 1)
    document = lean.to_dict()
    assert document["method"] == "mcm" and len(document["interval_shortest"]) == 2


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"trials": 0}, "trials must be an integer >= 2"),
        ({"trials": 2.5}, "trials"),
        ({"trials": 10}, "too few"),
        ({"p": 1.5}, "p must lie"),
        ({"p": 0.0}, "p must lie"),
        ({"adaptive": True, "tolerance": 0.0}, "positive"),
        ({"adaptive": True, "tolerance": -1.0}, "positive"),
        ({"adaptive": True, "tolerance": NumericalTolerance(0.1, eigenvalue=-1)}, "eigenvalue"),
        ({"adaptive": True, "criterion": "loose"}, "criterion"),
        ({"adaptive": True, "sequence_size": 500}, "100/\\(1 - p\\)"),
        ({"adaptive": True, "trials": 100}, "either trials"),
        ({"adaptive": True, "max_trials": 1000}, "max_trials"),
        ({"adaptive": True, "digits": 0}, "digits"),
        ({"chunk_size": 0}, "chunk_size"),
    ],
)
def test_bad_arguments_are_refused_by_name(kwargs, match):
    with pytest.raises(ValueError, match=match):
        monte_carlo(total, SUM_INPUTS, **kwargs)


def test_bad_model_shapes_and_inputs_are_refused():
    with pytest.raises(ModelEvaluationError, match="one row per trial"):
        monte_carlo(lambda x: x.sum(), SUM_INPUTS, trials=100)
    with pytest.raises(ValueError, match="tolerance has 1 entries for 2"):
        monte_carlo(lambda x: x[:, :2], SUM_INPUTS, adaptive=True, tolerance=[0.1])
    with pytest.raises(TypeError, match="sample"):
        monte_carlo(total, object(), trials=100)
    with pytest.raises(TypeError, match="callable"):
        monte_carlo(42, SUM_INPUTS, trials=100)
