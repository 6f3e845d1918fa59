"""The worked examples of the GUM (JCGM 100:2008, H.2, H.3) and of JCGM 101:2008 (9.2–9.4).

Published numbers are asserted to the digits printed in the documents (half a unit of the
last digit).  Monte Carlo numbers depend on the random draws, so each is checked against an
*exact* reference (Irwin–Hall sums, noncentral χ², with mpmath; 9.3 in closed form and by
quadrature), with a tolerance of 4 Monte Carlo standard deviations at the M used: for an
interval end y_α, σ = sqrt(α(1 − α)/M) / g(y_α) with g the exact density; for an estimate
u/√M; for u(y) u·sqrt((κ − 1)/(4M)) with κ the kurtosis.  The published Monte Carlo
figures carry the noise of their own run; where they are compared, the tolerance is
stated with the test.  The cases themselves are defined once, in
``examples/gum_jcgm_cases.py``.
"""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import mpmath
import numpy as np
import pytest
from scipy import optimize, stats

_SPEC = importlib.util.spec_from_file_location(
    "gum_jcgm_cases", Path(__file__).resolve().parents[2] / "examples" / "gum_jcgm_cases.py"
)
cases = importlib.util.module_from_spec(_SPEC)
sys.modules.setdefault("gum_jcgm_cases", cases)  # dataclasses look their module up
_SPEC.loader.exec_module(cases)

M = 10**6  # JCGM 101:2008, 9.2–9.4 use M = 10⁶
P = 0.95


def half_ulp(decimals: int) -> float:
    """Half a unit in the last printed digit."""
    return 0.5 * 10.0**-decimals


def end_sigma(alpha: float, density: float, trials: int = M) -> float:
    """Standard deviation of the Monte Carlo α-quantile: sqrt(α(1 − α)/M) / g(y_α)."""
    return math.sqrt(alpha * (1.0 - alpha) / trials) / density


# --------------------------------------------------------------------------- GUM H.2


def test_gum_h2_approach_1_reproduces_table_h4_with_one_ensemble_of_nu_4():
    """JCGM 100:2008, H.2.3 / Table H.4: R = 127.732 Ω, X = 219.847 Ω, Z = 254.260 Ω;
    u = 0.071, 0.295, 0.236 Ω; r(R, X) = −0.588, r(R, Z) = −0.485, r(X, Z) = 0.993.

    Approach 1 (means and their covariances) gives u(X) = 0.29558 Ω: the table's 0.295 is
    the approach-2 figure (0.29549, below); both round within 1 in the last digit, which is
    the tolerance for u(X).  The three inputs are one ensemble of ν = 4, so every ν_eff is
    exactly 4 (Willink 2007): without the ensemble the GUF refuses the correlated inputs.
    """
    result = cases.case_gum_h2().guf()
    np.testing.assert_allclose(result.estimate, [127.732, 219.847, 254.260], atol=half_ulp(3))
    assert result.standard_uncertainty[0] == pytest.approx(0.071, abs=half_ulp(3))
    assert result.standard_uncertainty[1] == pytest.approx(0.295, abs=2 * half_ulp(3))
    assert result.standard_uncertainty[2] == pytest.approx(0.236, abs=half_ulp(3))
    r = result.correlation
    np.testing.assert_allclose([r[0, 1], r[0, 2], r[1, 2]], [-0.588, -0.485, 0.993], atol=5e-4)
    np.testing.assert_allclose(result.dof_effective, 4.0, rtol=1e-12)
    # k = t_0.975(4) = 2.78 (JCGM 100:2008, Table G.2).
    np.testing.assert_allclose(result.coverage_factor, 2.78, atol=0.005)


def test_gum_h2_approach_2_type_a_of_the_computed_values():
    """JCGM 100:2008, H.2.4: R, X, Z computed from each set, then their means and
    experimental standard deviations of the mean: u = 0.071, 0.295, 0.236 Ω to the digit."""
    rxz = cases._impedance(cases.H2_OBSERVATIONS)  # (5, 3)
    inputs = cases.InputSet.from_observations(["R", "X", "Z"], rxz)
    np.testing.assert_allclose(inputs.estimate, [127.732, 219.847, 254.260], atol=half_ulp(3))
    np.testing.assert_allclose(inputs.standard_uncertainty, [0.071, 0.295, 0.236], atol=half_ulp(3))
    r = inputs.correlation
    np.testing.assert_allclose([r[0, 1], r[0, 2], r[1, 2]], [-0.588, -0.485, 0.993], atol=5e-4)


def test_gum_h2_without_an_ensemble_is_refused():
    from mtmetrology.errors import InputError

    h2 = cases.case_gum_h2()
    loose = cases.InputSet.from_covariance(
        h2.inputs.names, h2.inputs.estimate, h2.inputs.covariance, dof=[4, 4, 4]
    )
    with pytest.raises(InputError, match=r"inputs 'V' and 'I' are correlated .* ensemble"):
        cases.guf(h2.model, loose)


# --------------------------------------------------------------------------- GUM H.3


def test_gum_h3_least_squares_line_and_correction_at_30_degrees():
    """JCGM 100:2008, H.3.3–H.3.4: y₁ = −0.1712 °C, y₂ = 0.00218, s(y₁) = 0.0029 °C,
    s(y₂) = 0.00067, r(y₁, y₂) = −0.930, s = 0.0035 °C, ν = 9; b(30 °C) = −0.1494 °C with
    u = 0.0041 °C.  y₁ and y₂ are one ensemble of ν = 9, so ν_eff of b is exactly 9."""
    estimate, covariance, s, dof = cases.gum_h3_fit()
    assert estimate[0] == pytest.approx(-0.1712, abs=half_ulp(4))
    assert estimate[1] == pytest.approx(0.00218, abs=half_ulp(5))
    u = np.sqrt(np.diag(covariance))
    assert u[0] == pytest.approx(0.0029, abs=half_ulp(4))
    assert u[1] == pytest.approx(0.00067, abs=half_ulp(5))
    assert covariance[0, 1] / (u[0] * u[1]) == pytest.approx(-0.930, abs=half_ulp(3))
    assert s == pytest.approx(0.0035, abs=half_ulp(4)) and dof == 9
    correction = cases.case_gum_h3(30.0).guf().output()
    assert correction.value == pytest.approx(-0.1494, abs=half_ulp(4))
    assert correction.u == pytest.approx(0.0041, abs=half_ulp(4))
    assert correction.unit == "°C"
    assert cases.case_gum_h3(30.0).guf().dof_effective[0] == pytest.approx(9.0, rel=1e-12)


# --------------------------------------------------------------------------- JCGM 101 9.2


def _irwin_hall_cdf(n: int, x):
    """P(U₁ + … + U_n ≤ x), U_i ~ U(0, 1) (exact, mpmath)."""
    x = mpmath.mpf(x)
    total = sum((-1) ** k * mpmath.binomial(n, k) * (x - k) ** n for k in range(n + 1) if x > k)
    return min(max(total / mpmath.factorial(n), mpmath.mpf(0)), mpmath.mpf(1))


def _irwin_hall_integral(n: int, x):
    """∫_{−∞}^{x} P(S_n ≤ s) ds (exact, mpmath)."""
    x = mpmath.mpf(x)
    return sum(
        (-1) ** k * mpmath.binomial(n, k) * (x - k) ** (n + 1) for k in range(n + 1) if x > k
    ) / mpmath.factorial(n + 1)


def _rectangular_sum_cdf(y):
    """9.2.3: Y = Σ X_i, X_i ~ U(−√3, √3): Y = 2√3 (S₄ − 2)."""
    return _irwin_hall_cdf(4, mpmath.mpf(y) / (2 * mpmath.sqrt(3)) + 2)


def _wide_sum_cdf(y):
    """9.2.4: Y = 2√3 (S₃ − 3/2) + V, V ~ U(−10√3, 10√3): the S₃ CDF averaged over V."""
    root3 = mpmath.sqrt(3)
    high = (mpmath.mpf(y) + 10 * root3) / (2 * root3) + mpmath.mpf(1.5)
    low = (mpmath.mpf(y) - 10 * root3) / (2 * root3) + mpmath.mpf(1.5)
    return (_irwin_hall_integral(3, high) - _irwin_hall_integral(3, low)) / 10


def _symmetric_quantile(cdf, scale: float) -> tuple[float, float]:
    """The 97.5 % point y of a distribution symmetric about 0 and its density."""
    mpmath.mp.dps = 30
    y = mpmath.findroot(lambda v: cdf(v) - mpmath.mpf(0.975), scale)
    return float(y), float(mpmath.diff(cdf, y))


@pytest.mark.parametrize(
    ("kind", "published_guf", "published_mcm", "decimals"),
    [
        ("normal", 3.92, 3.92, 2),  # Table 2
        ("rectangular", 3.92, 3.88, 2),  # Table 3
        ("rectangular-wide", 19.9, 17.0, 1),  # Table 4
    ],
)
def test_jcgm101_9_2_additive_model(kind, published_guf, published_mcm, decimals):
    """JCGM 101:2008, 9.2, Tables 2–4: GUF interval ±published_guf, Monte Carlo (M = 10⁶)
    shortest interval ±published_mcm.  The exact distributions are symmetric about 0, so
    their shortest interval is the probabilistically symmetric one: the exact end (normal,
    Irwin–Hall) rounds to the published figure, and our Monte Carlo symmetric interval
    lies within 4σ of the exact end."""
    case = cases.case_jcgm101_9_2(kind)
    g = case.guf()
    # Sum of four inputs of u = 1 (and one of u = 10): u(y) = 2 or sqrt(103), exactly.
    exact_u = math.sqrt(103.0) if kind == "rectangular-wide" else 2.0
    assert g.output().u == pytest.approx(exact_u, rel=1e-12)
    assert g.output().interval[1] == pytest.approx(published_guf, abs=half_ulp(decimals))
    if kind == "normal":
        end, density = 1.959963984540054 * 2.0, stats.norm.pdf(1.959963984540054) / 2.0
    else:
        cdf = _rectangular_sum_cdf if kind == "rectangular" else _wide_sum_cdf
        end, density = _symmetric_quantile(cdf, published_mcm)
    assert end == pytest.approx(published_mcm, abs=half_ulp(decimals))
    r = case.monte_carlo(M, seed=92)
    tolerance = 4 * end_sigma(0.025, density)
    np.testing.assert_allclose(r.interval[0], [-end, end], atol=tolerance)
    assert r.output().u == pytest.approx(exact_u, abs=4 * exact_u / math.sqrt(M))
    assert r.output().value == pytest.approx(0.0, abs=4 * exact_u / math.sqrt(M))


def test_jcgm101_9_2_3_gum_framework_is_validated_for_two_digits():
    """JCGM 101:2008, 9.2.3.3: with n_dig = 2, δ = 0.05 and |3.92 − 3.88| = 0.04 ≤ δ."""
    case = cases.case_jcgm101_9_2("rectangular")
    report = cases.validate_results(case.guf(), case.monte_carlo(M, seed=923), digits=2)
    assert report.passed
    assert {row.tolerance for row in report.rows} == {0.05}


# --------------------------------------------------------------------------- JCGM 101 9.3
# The exact law of δm = X (1 + Z) − m_nom (JCGM 101:2008, 9.3.1, Table 5), with
# X = m_R,c + δm_R,c ~ N(100 001.234, 0.050² + 0.020²) mg and Z = (ρ_a − ρ_a0)(1/ρ_W − 1/ρ_R),
# ρ_a − ρ_a0 ~ R(−0.1, 0.1), ρ_W ~ R(7000, 9000), ρ_R ~ R(7950, 8050) kg/m³, all independent.
# Given Z, δm is normal; its distribution function is the mean over Z of those normal ones,
# an integral over the three rectangular inputs done by Gauss–Legendre quadrature (smooth
# integrand: 20 nodes a side already agree with 80 to 1e-12 mg).
MASS_X = (100_001.234, math.hypot(0.050, 0.020))  # mean and standard deviation of X, mg
MASS_NOMINAL = 100_000.0


def _mass_law(nodes: int = 24) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean, standard deviation (mg) and weight of the normal law of δm at each node."""
    x, w = np.polynomial.legendre.leggauss(nodes)
    a, rho_w, rho_r = np.meshgrid(0.1 * x, 8000.0 + 1000.0 * x, 8000.0 + 50.0 * x,
                                  indexing="ij")  # fmt: skip
    z = (a * (1.0 / rho_w - 1.0 / rho_r)).ravel()
    weight = (w[:, None, None] * w[None, :, None] * w[None, None, :]).ravel() / 8.0
    mean_x, sd_x = MASS_X
    return (mean_x - MASS_NOMINAL) + mean_x * z, sd_x * (1.0 + z), weight


def _mass_quantile(probability: float) -> float:
    mean, sd, weight = _mass_law()
    return optimize.brentq(lambda t: weight @ stats.norm.cdf(t, mean, sd) - probability,
                           0.5, 2.0, xtol=1e-12)  # fmt: skip


def _mass_density(t: float) -> float:
    mean, sd, weight = _mass_law()
    return float(weight @ stats.norm.pdf(t, mean, sd))


def _mass_moments() -> tuple[float, float, float]:
    """Exact mean, standard deviation and kurtosis of δm (normal moments given Z)."""
    mean, sd, weight = _mass_law()
    mu = float(weight @ mean)
    d = mean - mu
    variance = float(weight @ (d**2 + sd**2))
    fourth = float(weight @ (d**4 + 6 * d**2 * sd**2 + 3 * sd**4))
    return mu, math.sqrt(variance), fourth / variance**2


def _mass_u_closed_form() -> float:
    """u(δm)² = σ_X² + (μ_X² + σ_X²) Var(ρ_a) E[(1/ρ_W − 1/ρ_R)²], with E[1/ρ] = ln(b/a)/(b − a)
    and E[1/ρ²] = 1/(ab) for ρ ~ R(a, b) (E[ρ_a − ρ_a0] = 0 removes every other term)."""
    mean_x, sd_x = MASS_X
    inverse_w, inverse_r = math.log(9000 / 7000) / 2000, math.log(8050 / 7950) / 100
    b2 = 1 / (7000 * 9000) - 2 * inverse_w * inverse_r + 1 / (7950 * 8050)
    return math.sqrt(sd_x**2 + (mean_x**2 + sd_x**2) * (0.1**2 / 3) * b2)


@pytest.fixture(scope="module")
def mass_guf_and_mcm():
    case = cases.case_jcgm101_9_3()
    return case.guf(), case.monte_carlo(M, seed=93)


def test_jcgm101_9_3_exact_law_by_closed_form_and_quadrature():
    """u(δm) = 0.075480 mg in closed form, the same by quadrature, E[δm] = 1.234 mg; the
    probabilistically symmetric 95 % interval [1.08443, 1.38357] mg by quadrature."""
    mu, u, _ = _mass_moments()
    assert _mass_u_closed_form() == pytest.approx(0.075480, abs=half_ulp(6))
    assert u == pytest.approx(_mass_u_closed_form(), rel=1e-10)
    assert mu == pytest.approx(1.234, abs=1e-9)
    ends = [_mass_quantile(0.025), _mass_quantile(0.975)]
    np.testing.assert_allclose(ends, [1.08443, 1.38357], atol=half_ulp(5))


def test_jcgm101_9_3_mass_calibration_matches_the_published_figures(mass_guf_and_mcm):
    """JCGM 101:2008, 9.3, Table 6: GUF δm = 1.2340 mg, u = 0.0539 mg, [1.1285, 1.3395];
    MCM (M = 10⁶) 1.2341 mg, u = 0.0754 mg, shortest [1.0834, 1.3825]; d_low = 0.0451,
    d_high = 0.0430 > δ = 0.0005: the GUF is not validated.

    The published Monte Carlo figures carry the noise of their own run (the exact law, in
    the next test, gives u = 0.075480 mg and the shortest interval [1.08443, 1.38357] mg:
    the published ends are 1 mg·10⁻³ off).  The ends of a shortest interval of a nearly
    symmetric law vary by σ ≈ 6.5e-4 mg between seeds (measured over 8 seeds: the start
    of the shortest interval is a flat minimum).  Allowed: ½ unit of the last digit + 4√2 σ
    (two independent runs): 0.0005 mg for y and u, 0.0037 mg for the interval ends."""
    g, r = mass_guf_and_mcm
    assert g.output().value == pytest.approx(1.2340, abs=half_ulp(4))
    assert g.output().u == pytest.approx(0.0539, abs=half_ulp(4))
    np.testing.assert_allclose(g.output().interval, [1.1285, 1.3395], atol=half_ulp(4))
    noise_y = half_ulp(4) + 4 * math.sqrt(2) * 0.0754 / math.sqrt(M)
    assert r.output().value == pytest.approx(1.2341, abs=noise_y)
    assert r.output().u == pytest.approx(0.0754, abs=noise_y)
    noise_end = half_ulp(4) + 4 * math.sqrt(2) * 6.5e-4
    np.testing.assert_allclose(r.interval_shortest[0], [1.0834, 1.3825], atol=noise_end)
    report = cases.validate_results(g, r, digits=2)
    assert not report.passed
    assert report.rows[0].tolerance == pytest.approx(0.0005)
    assert [row.difference for row in report.rows] == pytest.approx([0.0451, 0.0430], abs=0.004)


def test_jcgm101_9_3_monte_carlo_agrees_with_the_exact_law(mass_guf_and_mcm):
    """Our M = 10⁶ run against the exact law within 4 of its own standard deviations:
    y to 4u/√M = 3.0e-4 mg; u to 4u·sqrt((κ − 1)/(4M)) = 2.2e-4 mg (κ = 3.10, exact);
    each end of the probabilistically symmetric interval to 4·sqrt(α(1 − α)/M)/g = 8.4e-4
    mg (g = 0.739 /mg, the exact density there); the length of the shortest interval to
    4·sqrt((2·0.025·0.975 − 2·0.025²)/M)/g = 1.2e-3 mg (the covariance of two quantiles).

    A normal interval with the exact u, 1.234 ± 1.96 u = [1.0861, 1.3819] mg, misses the
    ends by 1.6e-3 mg (7.7 σ) and the length by 3.3e-3 mg (11 σ): these tolerances tell it
    apart, which the published figures' (0.0037 mg) could not."""
    _, r = mass_guf_and_mcm
    mu, u, kurtosis = _mass_moments()
    assert 3.0 < kurtosis < 3.2
    assert r.output().value == pytest.approx(mu, abs=4 * u / math.sqrt(M))
    assert r.output().u == pytest.approx(u, abs=4 * u * math.sqrt((kurtosis - 1) / (4 * M)))
    ends = np.array([_mass_quantile(0.025), _mass_quantile(0.975)])
    sigma = [end_sigma(0.025, _mass_density(ends[0])), end_sigma(0.975, _mass_density(ends[1]))]
    np.testing.assert_allclose(r.interval[0], ends, rtol=0, atol=4 * max(sigma))
    normal = mu + np.array([-1.0, 1.0]) * stats.norm.ppf(0.975) * u
    assert np.all(np.abs(normal - ends) > 7 * max(sigma))
    # The exact shortest interval is the symmetric one to 3e-8 mg (the law is nearly
    # symmetric): its length is ends[1] − ends[0].
    length = ends[1] - ends[0]
    covariance = (2 * 0.025 * 0.975 - 2 * 0.025**2) / M
    sigma_length = math.sqrt(covariance) / _mass_density(ends[0])
    shortest = r.interval_shortest[0]
    assert shortest[1] - shortest[0] == pytest.approx(length, abs=4 * sigma_length)
    assert shortest[1] - shortest[0] <= r.interval[0][1] - r.interval[0][0]
    assert abs(np.diff(normal)[0] - length) > 2 * 4 * sigma_length


# --------------------------------------------------------------------------- JCGM 101 9.4


def _noncentral_shortest(x1: float, u: float) -> tuple[float, float]:
    """Shortest 95 % interval of u² χ'²₂((x₁/u)²), the exact law of X₁² + X₂² for r = 0."""
    law = stats.ncx2(df=2, nc=(x1 / u) ** 2, scale=u**2) if x1 else stats.chi2(2, scale=u**2)

    def length(start_probability):
        return law.ppf(start_probability + P) - law.ppf(start_probability)

    best = optimize.minimize_scalar(length, bounds=(0.0, 1.0 - P), method="bounded",
                                    options={"xatol": 1e-12})  # fmt: skip
    start = 0.0 if length(0.0) <= best.fun else best.x
    return float(law.ppf(start)), float(law.ppf(start + P))


@pytest.mark.parametrize("x1", [0.0, 0.010, 0.050])
def test_jcgm101_9_4_comparison_loss_independent_inputs(x1):
    """JCGM 101:2008, 9.4.2 (r = 0): the GUF gives y = x₁², u(y) = 2 x₁ u (0, 1.0e-4,
    5.0e-4; for x₁ = 0 it gives u(y) = 0, the failure the clause exhibits), interval
    y ± 1.96 u(y).  The exact law is u² χ'²₂(λ = x₁²/u²): E = x₁² + 2u², V = 4u⁴(1 + λ),
    so y = 5.0e-5, 1.5e-4, 2.55e-3 and u(y) = 5.0e-5, 1.12e-4, 5.02e-4; the Monte Carlo
    estimate, u and shortest interval agree with it within 4σ (σ of the upper end from the
    exact density)."""
    u = 0.005
    case = cases.case_jcgm101_9_4(x1, 0.0, u)
    g = case.guf().output()
    assert g.value == pytest.approx(x1**2, abs=1e-18)
    assert g.u == pytest.approx(2 * x1 * u, abs=1e-18)
    np.testing.assert_allclose(g.interval, x1**2 + np.array([-1.0, 1.0]) * 1.959964 * g.u,
                               atol=1e-9)  # fmt: skip
    exact_y = x1**2 + 2 * u**2
    exact_u = 2 * u**2 * math.sqrt(1 + (x1 / u) ** 2)
    r = case.monte_carlo(M, seed=94)
    assert r.output().value == pytest.approx(exact_y, abs=4 * exact_u / math.sqrt(M))
    # Var of the sample variance ≈ (μ₄ − σ⁴)/M; μ₄ ≤ 9σ⁴ for these laws, so σ(u) ≤ 2u/√M.
    assert r.output().u == pytest.approx(exact_u, abs=4 * 2 * exact_u / math.sqrt(M))
    low, high = _noncentral_shortest(x1, u)
    law = stats.ncx2(df=2, nc=(x1 / u) ** 2, scale=u**2)
    sigma_high = end_sigma(0.05, float(law.pdf(high)))
    assert r.interval_shortest[0, 1] == pytest.approx(high, abs=4 * sigma_high)
    assert r.interval_shortest[0, 0] == pytest.approx(low, abs=4 * sigma_high)


@pytest.mark.parametrize("x1", [0.0, 0.010, 0.050])
def test_jcgm101_9_4_comparison_loss_correlated_inputs(x1):
    """JCGM 101:2008, 9.4.3 (r = 0.9): the GUF is unchanged (x₂ = 0 has zero sensitivity),
    the exact moments of the quadratic form XᵀX, X ~ N((x₁, 0), u²[[1, r], [r, 1]]), are
    E = x₁² + 2u², V = 4u⁴(1 + r²) + 4x₁²u², and Monte Carlo agrees within 4σ."""
    u, rho = 0.005, 0.9
    case = cases.case_jcgm101_9_4(x1, rho, u)
    assert case.guf().output().u == pytest.approx(2 * x1 * u, abs=1e-18)
    exact_y = x1**2 + 2 * u**2
    exact_u = math.sqrt(4 * u**4 * (1 + rho**2) + 4 * x1**2 * u**2)
    r = case.monte_carlo(M, seed=943)
    assert r.output().value == pytest.approx(exact_y, abs=4 * exact_u / math.sqrt(M))
    assert r.output().u == pytest.approx(exact_u, abs=4 * 2 * exact_u / math.sqrt(M))
