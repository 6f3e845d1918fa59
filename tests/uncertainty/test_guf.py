"""Tests for mtmetrology.uncertainty.guf (JCGM 100 / JCGM 102)."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mtmetrology.errors import ConvergenceError, InputError
from mtmetrology.uncertainty.distributions import Normal, Rectangular, StudentT
from mtmetrology.uncertainty.guf import guf, variance_shares, welch_satterthwaite
from mtmetrology.uncertainty.inputs import InputQuantity, InputSet
from mtmetrology.uncertainty.mcm import monte_carlo
from mtmetrology.uncertainty.modelfile import load_model
from mtmetrology.uncertainty.regions import (
    ellipse_area,
    normal_ellipsoidal_coverage_factor,
    normal_rectangular_coverage_factor,
    rectangle_area,
)
from mtmetrology.units import to_internal

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "gum-h1-end-gauge.yaml"

# Upper triangle of the correlation matrix of Sepahi Boroujeni (2021), Table 5-4 (13 geometric
# errors,
# order E_A0B E_C0B E_X0C E_A0C E_B0C E_B0Z E_A0Y E_C0Y E_XX1 E_YY1 E_ZZ1 E_Y0S E_X0S).
TABLE_5_4_UPPER = [
    [0.189, -0.035, 0.058, -0.089, 0.365, 0.509, 0.415, 0.037, 0.008, 0.255, -0.641, -0.297],
    [-0.486, 0.163, 0.254, 0.204, 0.534, 0.828, 0.276, 0.199, 0.274, 0.1, -0.491],
    [-0.163, 0.08, 0.136, -0.438, -0.275, -0.103, -0.049, 0.025, 0.019, 0.54],
    [-0.328, 0.005, 0.517, 0.012, -0.209, -0.143, -0.135, -0.497, 0.06],
    [0.577, 0.061, 0.174, 0.43, 0.377, 0.34, 0.385, -0.207],
    [0.096, 0.283, 0.113, 0.124, 0.301, -0.315, -0.141],
    [0.489, 0.183, 0.174, 0.222, -0.3, -0.398],
    [0.38, 0.328, 0.444, 0.002, -0.672],
    [0.965, 0.906, 0.273, -0.58],
    [0.929, 0.259, -0.472],
    [0.003, -0.444],
    [0.001],
]
# Table 5-2, MCM standard uncertainties (µrad, µm, µm/m as listed).
TABLE_5_2_U_MCM = [0.86, 0.80, 0.48, 0.86, 0.96, 1.26, 1.12, 0.89, 6.1, 5.4, 5.5, 0.88, 1.03]


def table_5_4_correlation() -> np.ndarray:
    r = np.eye(13)
    for i, row in enumerate(TABLE_5_4_UPPER):
        r[i, i + 1 :] = row
        r[i + 1 :, i] = row
    return r


def normals(estimates, uncertainties, dof=None, correlation=None) -> InputSet:
    dof = dof or [None] * len(estimates)
    qs = [
        InputQuantity(f"x{i + 1}", Normal(x, u), dof=d)
        for i, (x, u, d) in enumerate(zip(estimates, uncertainties, dof, strict=True))
    ]
    return InputSet(qs, correlation)


def _random_linear_problem(m: int, n: int, seed: int):
    """A (m, N), x (N,), a positive definite U_x (N, N) and the normal InputSet."""
    rng = np.random.default_rng(seed)
    a = rng.normal(size=(m, n))
    factor = rng.normal(size=(n, n))
    covariance = factor @ factor.T + 0.1 * np.eye(n)
    x = rng.normal(size=n)
    return a, x, covariance, InputSet.from_covariance([f"x{i}" for i in range(n)], x, covariance)


# --------------------------------------------------------------------------- GUM H.1


def test_gum_h1_combined_uncertainty_is_32_nm():
    """JCGM 100:2008 H.1.6: l = 50.000 838 mm, u_c(l) = 32 nm (31.7 nm unrounded)."""
    m = load_model(EXAMPLE)
    r = guf(m.model, m.inputs, p=0.99)
    assert r.estimate[0] == pytest.approx(50_000_838.6, abs=0.05)
    assert r.standard_uncertainty[0] == pytest.approx(31.7, abs=0.05)
    assert round(r.standard_uncertainty[0]) == 32
    assert r.units == ("nm",)


def test_gum_h1_effective_dof_16_and_expanded_uncertainty_93_nm():
    """JCGM 100:2008 H.1.6: ν_eff = 16.7 → 16 (G.4.1 truncation), t_99(16) = 2.92, U_99 = 93 nm.

    Welch–Satterthwaite (G.2b) on the Table H.2 contributions, unrounded: l_s 25 nm (ν = 18),
    d 9.7 nm (ν = 25.6), δα l_s·0.1 °C·0.58e-6/°C = 2.90 nm (ν = 50), δθ l_s·11.5e-6/°C·0.029
    °C = 16.675 nm (ν = 2) give ν_eff = 16.656; the annex rounds δθ to 16.6 nm first and
    prints 16.7.  The tolerance 0.01 catches a ν_eff that drops the ν(d) = 25.6 term
    (16.751); either way the truncated value is 16.
    """
    m = load_model(EXAMPLE)
    r = guf(m.model, m.inputs, p=0.99)
    l_s = 50_000_623.6  # nm
    contributions = np.array([25.0, 9.7, l_s * 0.1 * 0.58e-6, l_s * 11.5e-6 * 0.029])  # nm
    dof = np.array([18.0, 25.6, 50.0, 2.0])
    u_c = math.sqrt(np.sum(contributions**2))
    nu_eff = u_c**4 / np.sum(contributions**4 / dof)
    assert nu_eff == pytest.approx(16.656, abs=0.0005)
    assert r.dof_effective[0] == pytest.approx(nu_eff, rel=1e-9)
    assert r.dof_effective[0] == pytest.approx(16.656, abs=0.01)
    without_d = u_c**4 / np.sum(np.delete(contributions**4 / dof, 1))
    assert abs(without_d - 16.656) > 0.05
    assert r.coverage_factor[0] == pytest.approx(2.92, abs=0.005)
    assert round(r.expanded_uncertainty[0]) == 93
    rows = {row.input: row for row in r.budget("l")}
    # Table H.2 contributions: 25, 9.7, 0, 0, 2.9, 16.6 nm.
    assert rows["l_s"].contribution == pytest.approx(25.0)
    assert rows["d"].contribution == pytest.approx(9.7)
    assert rows["alpha_s"].contribution == 0.0 and rows["theta"].contribution == 0.0
    assert rows["dalpha"].contribution == pytest.approx(2.9, abs=0.005)
    assert rows["dtheta"].contribution == pytest.approx(16.6, abs=0.1)
    assert sum(row.share for row in r.budget(0)) == pytest.approx(1.0)


def test_gum_h1_second_order_terms_give_34_nm():
    """JCGM 100:2008 H.1.7: with the second-order terms u_c(l) = 34 nm.

    The first-order GUF drops the products δα·θ and α_s·δθ, whose expectations are 0
    but whose variances are l_s² u²(δα) u²(θ) = (11.9 nm)² and l_s² u²(α_s) u²(δθ) =
    (1.7 nm)² (JCGM 100 5.1.2 note).  A direct Monte Carlo of the model with these
    normal inputs confirms 33.9 nm (2·10⁵ draws: s.e. of the std ≈ 0.1 nm; ±0.5 nm).
    """
    m = load_model(EXAMPLE)
    r = guf(m.model, m.inputs, p=0.99)
    ls = m.inputs.estimate[0]
    u = dict(zip(m.inputs.names, m.inputs.standard_uncertainty, strict=True))
    second = [ls * u["dalpha"] * u["theta"], ls * u["alpha_s"] * u["dtheta"]]
    assert second[0] == pytest.approx(11.9, abs=0.05) and second[1] == pytest.approx(1.74, abs=0.01)
    u2 = math.sqrt(r.standard_uncertainty[0] ** 2 + sum(s**2 for s in second))
    assert u2 == pytest.approx(33.9, abs=0.05) and round(u2) == 34
    y = m.model(m.inputs.sample(np.random.default_rng(1), 200_000))[:, 0]
    assert y.std() == pytest.approx(33.9, abs=0.5)


# --------------------------------------------------------------------------- exact results


def test_sum_of_normals_is_exact():
    """u² = 0.3² + 0.4² + 1.2² = 1.69 exactly; ν_eff is checked against GTC in test_gtc."""
    s = normals([1.0, 2.0, 3.0], [0.3, 0.4, 1.2], dof=[None, 8, 20])
    r = guf(lambda x: x[..., 0] + x[..., 1] + x[..., 2], s)
    assert r.scalar_model and r.estimate[0] == pytest.approx(6.0)
    assert r.standard_uncertainty[0] == pytest.approx(1.3, rel=1e-15)
    assert r.names == ("y",)


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 4), st.integers(1, 5), st.integers(0, 2**32 - 1))
def test_linear_model_gives_exact_covariance(m, n, seed):
    """Y = A X: U_y = A U_x Aᵀ exactly, for correlated inputs and numerical sensitivities."""
    a, x, cov, s = _random_linear_problem(m, n, seed)
    r = guf(lambda xx: xx @ a.T, s)
    np.testing.assert_allclose(r.estimate, a @ x, atol=1e-12)
    np.testing.assert_allclose(r.covariance, a @ cov @ a.T, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(r.sensitivities, a, rtol=1e-8, atol=1e-10)
    # Full-covariance shares always sum to one.
    assert sum(row.share for row in r.budget(0)) == pytest.approx(1.0)


def test_analytic_and_numerical_sensitivities_agree_and_zero_variance_is_skipped():
    s = normals([2.0, 0.5, 3.0], [1e-3, 2e-3, 0.0])
    calls = []

    def f(x):
        calls.append(np.shape(x))
        return np.stack(
            [x[..., 0] ** 2 * np.sin(x[..., 1]), np.exp(x[..., 0]) * x[..., 2]], axis=-1
        )

    def jac(x):
        x1, x2, x3 = x
        return np.array(
            [[2 * x1 * np.sin(x2), x1**2 * np.cos(x2), 0.0], [np.exp(x1) * x3, 0.0, np.exp(x1)]]
        )

    numeric = guf(f, s)
    analytic = guf(f, s, jacobian=jac)
    # Central differences with step u: error O(u²) relative ≈ 1e-6.
    np.testing.assert_allclose(
        numeric.sensitivities[:, :2], analytic.sensitivities[:, :2], rtol=1e-5
    )
    np.testing.assert_allclose(numeric.covariance, analytic.covariance, rtol=1e-5)
    # x3 has zero variance: not perturbed (one batch of 2·2 points), sensitivity left 0.
    assert (4, 3) in calls
    assert numeric.sensitivities[1, 2] == 0.0 and analytic.sensitivities[1, 2] == pytest.approx(
        np.exp(2.0)
    )
    assert analytic.sensitivity_method == "analytic"
    assert numeric.sensitivity_method == "central differences"
    assert analytic.newton_iterations == numeric.newton_iterations == 0


def test_implicit_model_matches_explicit():
    """h(Y, X) = Y² − X1·X2 = 0, Y > 0: C = −C_y⁻¹ C_x equals ∂sqrt(X1 X2)/∂X (JCGM 102 6.2.2)."""
    s = normals([4.0, 9.0], [0.1, 0.2])
    analytic = [[0.5 * math.sqrt(9.0 / 4.0), 0.5 * math.sqrt(4.0 / 9.0)]]
    explicit = guf(lambda x: np.sqrt(x[..., 0] * x[..., 1]), s, jacobian=lambda x: analytic)

    def h(y, x):
        return y**2 - (x[..., 0] * x[..., 1])[..., None]

    implicit = guf(h, s, implicit=True, y0=[5.0])
    assert implicit.estimate[0] == pytest.approx(6.0, rel=1e-12)
    np.testing.assert_allclose(implicit.sensitivities, explicit.sensitivities, rtol=1e-6)
    assert implicit.standard_uncertainty[0] == pytest.approx(
        explicit.standard_uncertainty[0], rel=1e-6
    )
    assert implicit.newton_iterations >= 1 and implicit.sensitivity_method == "central differences"


def test_implicit_linear_system_with_analytic_jacobian():
    """A y − x = 0: y = A⁻¹x and U_y = A⁻¹ U_x A⁻ᵀ; sign of C = −C_y⁻¹C_x checked."""
    a = np.array([[2.0, 1.0], [0.5, 3.0]])
    s = normals([1.0, -2.0], [0.1, 0.3])
    ainv = np.linalg.inv(a)
    r = guf(
        lambda y, x: y @ a.T - x,
        s,
        implicit=True,
        y0=[0.0, 0.0],
        jacobian=lambda y, x: (a, -np.eye(2)),
    )
    np.testing.assert_allclose(r.estimate, ainv @ [1.0, -2.0])
    np.testing.assert_allclose(r.sensitivities, ainv)
    np.testing.assert_allclose(r.covariance, ainv @ np.diag([0.01, 0.09]) @ ainv.T)


def test_implicit_model_without_a_root_raises_convergence_error_naming_the_residual():
    """h(Y, X) = Y² + X² has no real root: ‖h‖ cannot go below X² = 4 (reached at Y = 0)."""
    s = normals([2.0], [0.1])
    with pytest.raises(ConvergenceError) as raised:
        guf(lambda y, x: y**2 + x**2, s, implicit=True, y0=[1.0], max_iter=30)
    message = str(raised.value)
    residual = float(re.search(r"residual \|h\| = (\S+) ", message).group(1))
    steps = int(re.search(r"after (\d+) steps", message).group(1))
    assert residual == pytest.approx(4.0, rel=1e-3) and 1 <= steps <= 30


def test_implicit_newton_iteration_limit_is_a_convergence_error():
    """One step from far away cannot solve Y³ = X: the limit is reported, not a wrong y."""
    s = normals([8.0], [0.1])
    with pytest.raises(ConvergenceError, match=r"iteration limit .* after 1 steps"):
        guf(lambda y, x: y**3 - x, s, implicit=True, y0=[10.0], max_iter=1)
    solved = guf(lambda y, x: y**3 - x, s, implicit=True, y0=[10.0])
    assert solved.estimate[0] == pytest.approx(2.0, rel=1e-12)


# ------------------------------------------------- Sepahi Boroujeni (2021) numbers


@pytest.mark.parametrize(("m", "k_p"), [(1, 1.96), (6, 3.55), (13, 4.73)])
def test_sepahi_boroujeni_hyperellipsoid_coverage_factors(m, k_p):
    """Sepahi Boroujeni (2021), Table 5-3: k_p = sqrt(χ²_m(0.95)) = 1.96, 3.55, 4.73."""
    s = normals(np.zeros(m), np.ones(m))
    r = guf(lambda x: x, s)
    assert r.region_coverage_factor == pytest.approx(k_p, abs=0.005)
    assert normal_ellipsoidal_coverage_factor(m) == pytest.approx(k_p, abs=0.005)


def test_sepahi_boroujeni_table_5_4_largest_eigenvalue_4_47():
    """Sepahi Boroujeni (2021), Table 5-3: λ_max of the Table 5-4 correlation matrix is 4.47
    (4.4685), PD."""
    r_in = table_5_4_correlation()
    s = normals(np.zeros(13), TABLE_5_2_U_MCM, correlation=r_in)
    r = guf(lambda x: x, s)  # identity model: outputs carry the input correlation
    np.testing.assert_allclose(r.correlation, r_in, atol=1e-9)
    assert r.largest_eigenvalue == pytest.approx(4.4685, abs=5e-4)
    assert round(r.largest_eigenvalue, 2) == 4.47
    assert np.linalg.eigvalsh(r_in)[0] == pytest.approx(0.0051, abs=1e-4)
    assert r.rectangular_coverage_factor == pytest.approx(normal_rectangular_coverage_factor(13))


def test_sepahi_boroujeni_pairwise_areas():
    """Sepahi Boroujeni (2021), Ch. 5: E_XX1–E_YY1 ellipse 162.6, Bonferroni rectangle 662 (µm/m)²;
    E_Y0S–E_X0S ellipse 17.25, rectangle 18.42 (GUF, u = 0.89, 1.03 µm), 18.13 with the
    independent-outputs factor and MCM u = 0.88 µm.  Inputs have 2-3 significant figures,
    so the published areas are matched to 0.1 %."""
    k_q = normal_rectangular_coverage_factor(2)
    k_p2 = normal_ellipsoidal_coverage_factor(2)
    assert k_q == pytest.approx(2.2414, abs=1e-4)
    assert normal_rectangular_coverage_factor(2, independent=True) == pytest.approx(
        2.2365, abs=1e-4
    )
    assert ellipse_area(k_p2, 6.1, 5.4, 0.965) == pytest.approx(162.6, rel=1e-3)
    assert rectangle_area(k_q, 6.1, 5.4) == pytest.approx(662.0, rel=1e-3)
    assert ellipse_area(k_p2, 0.89, 1.03, 0.001) == pytest.approx(17.25, rel=1e-3)
    assert rectangle_area(k_q, 0.89, 1.03) == pytest.approx(18.42, rel=1e-3)
    assert rectangle_area(
        normal_rectangular_coverage_factor(2, independent=True), 0.88, 1.03
    ) == pytest.approx(18.13, rel=1e-3)


def test_sepahi_boroujeni_one_dimensional_covariance_example_gives_1_um_not_2_2():
    """Sepahi Boroujeni (2021), Ch. 6, eqs. 6-8…6-12: ψ = γ(1 + δ) with [γ; δ] = [100 mm; −50 µm/m],
    var(γ) = 2.0 µm², cov(γ, δ) = −1.0e-2 mm·µm/m, var(δ) = 100 (µm/m)².

    First order: u²(ψ) = c_γ² u²(γ) + c_δ² u²(δ) + 2 c_γ c_δ cov(γ, δ) with c_γ ≈ 1 and
    c_δ = γ = 100 mm, i.e. 2.0 + 1.0 − 2·1.0 = 1.0 µm², u(ψ) = 1.0 µm.  The thesis's
    2.2 µm is √5 µm: the covariance term added (+2) instead of subtracted.  1.4 µm = √(1 + 1)
    is the short-term-only value the thesis also quotes."""
    var_gamma = to_internal(to_internal(2.0, "µm"), "µm")  # mm²
    cov_gd = to_internal(to_internal(-1.0e-2, "mm"), "µm/m")  # mm · 1
    var_delta = to_internal(to_internal(100.0, "µm/m"), "µm/m")
    cov = np.array([[var_gamma, cov_gd], [cov_gd, var_delta]])
    np.testing.assert_allclose(cov, [[2.0e-6, -1.0e-8], [-1.0e-8, 1.0e-10]])
    s = InputSet.from_covariance(["gamma", "delta"], [100.0, -50e-6], cov, ["mm", "1"])
    r = guf(lambda x: x[..., 0] * (1 + x[..., 1]), s)
    u_psi_um = r.standard_uncertainty[0] / to_internal(1.0, "µm")
    assert u_psi_um == pytest.approx(1.0, abs=1e-3)
    # The thesis figure: same terms with the sign of the covariance term flipped.
    c = r.sensitivities[0]
    wrong = c[0] ** 2 * cov[0, 0] + c[1] ** 2 * cov[1, 1] - 2 * c[0] * c[1] * cov[0, 1]
    assert math.sqrt(wrong) / 1e-3 == pytest.approx(math.sqrt(5.0), rel=1e-3)
    assert round(math.sqrt(wrong) / 1e-3, 1) == 2.2
    # The variance shares expose the negative covariance contribution that the thesis lost.
    shares = [row.share for row in r.budget(0)]
    assert sum(shares) == pytest.approx(1.0)


# --------------------------------------------------------------------------- coverage


@pytest.mark.slow
def test_guf_95_percent_interval_covers_true_value_95_percent():
    """For a normal linear model, y ± 1.96 u covers the true value in 95 ± 1 % of 10 000
    simulated measurements (binomial s.e. 0.22 %: the band is 4.5 s.e.; fixed seed)."""
    rng = np.random.default_rng(2026)
    truth = np.array([10.0, -3.0])
    u = np.array([0.2, 0.5])
    hits = 0
    for _ in range(10_000):
        x = truth + u * rng.standard_normal(2)
        r = guf(lambda xx: 2.0 * xx[..., 0] + xx[..., 1], normals(x, u))
        lo, hi = r.interval[0]
        hits += lo <= 2.0 * truth[0] + truth[1] <= hi
    assert hits / 10_000 == pytest.approx(0.95, abs=0.01)


# --------------------------------------------------------------------------- bad input


def test_welch_satterthwaite_refuses_correlated_finite_dof_inputs():
    r = np.array([[1.0, 0.5], [0.5, 1.0]])
    s = normals([0.0, 0.0], [1.0, 1.0], dof=[5, None], correlation=r)
    with pytest.raises(InputError, match=r"inputs 'x1' and 'x2' are correlated .* ensemble"):
        guf(lambda x: x[..., 0] + x[..., 1], s)


def test_infinite_variance_and_nan_model_and_missing_y0():
    s = InputSet(
        [InputQuantity("t", StudentT(0.0, 1.0, 2.0)), InputQuantity("r", Rectangular(0, 1))]
    )
    with pytest.raises(ValueError, match=r"inputs \['t'\] have infinite variance"):
        guf(lambda x: x[..., 0], s)
    ok = normals([1.0], [0.1])
    with pytest.raises(ValueError, match="non-finite estimate"):
        with np.errstate(invalid="ignore"):
            guf(lambda x: np.log(x[..., 0] - 2.0), ok)
    with pytest.raises(ValueError, match="needs a starting point y0"):
        guf(lambda y, x: y - x, ok, implicit=True)
    with pytest.raises(ValueError, match=r"p must lie in \(0, 1\)"):
        guf(lambda x: x[..., 0], ok, p=95)


def test_welch_satterthwaite_helper():
    """Designed cases with exact answers: all ν infinite -> inf; two equal unit
    contributions, one of ν = 4: ν_eff = 2²/(1/4) = 16; an ensemble of two perfectly
    correlated inputs of ν = 5 is one component: ν_eff = 5 whatever else is infinite."""
    eye = np.eye(2)
    assert welch_satterthwaite([1.0, 1.0], eye, [math.inf, math.inf]) == math.inf
    assert welch_satterthwaite([1.0, 1.0], eye, [4.0, math.inf]) == pytest.approx(16.0)
    ones = np.ones((2, 2))
    assert welch_satterthwaite([1.0, 1.0], ones, [5.0, 5.0], [0, 0]) == pytest.approx(5.0)
    with pytest.raises(InputError, match="'a' and 'b' are correlated"):
        welch_satterthwaite([1.0, 1.0], ones, [5.0, 5.0], names=["a", "b"])


@settings(max_examples=15, deadline=None)
@given(st.integers(1, 3), st.integers(1, 4), st.integers(0, 2**32 - 1))
def test_linear_model_guf_equals_monte_carlo(m, n, seed):
    """For Y = A X with X multivariate normal the GUF is exact: the Monte Carlo estimate and
    u(y) agree with it within 5 standard errors (u/√M and u/√(2M)), the probabilistically
    symmetric interval ends within 5σ of the quantile, at M = 2·10⁴."""
    a, _, _, inputs = _random_linear_problem(m, n, seed)
    trials = 20_000
    g = guf(lambda v: v @ a.T, inputs)
    r = monte_carlo(lambda v: v @ a.T, inputs, trials=trials, seed=seed)
    u = g.standard_uncertainty
    np.testing.assert_allclose(r.estimate, g.estimate, atol=5 * u.max() / math.sqrt(trials))
    np.testing.assert_allclose(r.standard_uncertainty, u, rtol=5 / math.sqrt(2 * trials))
    # σ of the 2.5 % quantile of a normal: sqrt(0.025·0.975/M)/φ(1.96) · u = 2.67 u/√M.
    np.testing.assert_allclose(r.interval, g.interval, atol=5 * 2.67 * u.max() / math.sqrt(trials))


def test_budget_shares_are_variance_contributions_that_sum_to_one_with_correlations():
    """y = x1 − x2, u = (1, 2), u(x1, x2) = 1.5: u_c² = 1 + 4 − 2·1.5 = 2 exactly.

    c_i Σ_j c_j u(x_i, x_j) / u_c²: x1 (1 − 1.5)/2 = −0.25, x2 (4 − 1.5)/2 = 1.25.
    The former u_i²/u_c² gave 0.5 and 2.0 (250 % in all).
    """
    cov = np.array([[1.0, 1.5], [1.5, 4.0]])
    s = InputSet.from_covariance(["x1", "x2"], [0.0, 0.0], cov, ["mm", "mm"])
    r = guf(lambda x: x[..., 0] - x[..., 1], s, jacobian=lambda _x: np.array([[1.0, -1.0]]))
    rows = r.budget(0)
    assert r.standard_uncertainty[0] ** 2 == pytest.approx(2.0)
    assert [b.share for b in rows] == pytest.approx([-0.25, 1.25])
    assert [b["share"] for b in r.to_dict()["budget"]["y"]] == pytest.approx([-0.25, 1.25])
    assert variance_shares([[1.0, -1.0]], cov, {"both": [0, 1]})["both"] == pytest.approx(1.0)
    # uncorrelated: the shares are u_i²(y)/u_c²(y) (JCGM 100, 5.1.3)
    assert variance_shares([1.0, 1.0], np.diag([1.0, 3.0])) == pytest.approx([0.25, 0.75])
