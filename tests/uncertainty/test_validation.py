"""Validation of the GUF by Monte Carlo (JCGM 101 §8, JCGM 102 §8,
Sepahi Boroujeni 2021, eqs. 7-3/7-4)."""

import json

import numpy as np
import pytest
from rich.console import Console

from mtmetrology.uncertainty.inputs import InputSet
from mtmetrology.uncertainty.mcm import monte_carlo
from mtmetrology.uncertainty.validation import (
    NumericalTolerance,
    ValidationRow,
    validate_guf,
)


def normal_inputs(mean, std):
    """Independent normal inputs x0, x1, ... as an InputSet (picklable for workers)."""
    std = np.asarray(std, dtype=float)
    return InputSet.from_covariance([f"x{i}" for i in range(std.size)], mean, np.diag(std**2))


def test_linear_scalar_model_is_validated():
    """Y = X1 + 2 X2, X ~ N((1, 2), diag(0.1², 0.2²)): GUF is exact, y = 5, u = 0.4123.
    δ = 0.005 (2 digits of u). At M = 10⁶ the MCM interval ends have standard deviations of
    about 0.0012, so d_low and d_high are well inside δ."""
    inputs = normal_inputs([1.0, 2.0], [0.1, 0.2])
    mcm = monte_carlo(lambda x: x[:, 0] + 2 * x[:, 1], inputs, trials=1_000_000, seed=1)
    u = np.sqrt(0.1**2 + 4 * 0.2**2)
    report = validate_guf(5.0, u**2, mcm, tolerance=0.005)
    assert report.passed
    assert [row.quantity for row in report.rows] == ["interval low", "interval high"]
    assert report.procedure == "JCGM 101:2008 §8"
    low = report.rows[0]
    assert low.guf == pytest.approx(5.0 - 1.959964 * u)
    assert low.difference == pytest.approx(abs(low.guf - mcm.interval[0, 0]))
    assert low.ratio < 1.0 and report.failed == ()


def test_linear_vector_model_is_validated_with_jcgm102_rows():
    """Y = A X with m = 2: rows for y and u of each output, λ_max and k_p (2m + 2 rows);
    GUF k_p = sqrt(χ²_2(0.95)) = 2.4477 against the sample k_p."""
    a = np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 1.0]])
    inputs = normal_inputs([1.0, 2.0, 3.0], [0.1, 0.2, 0.3])
    mcm = monte_carlo(lambda x: x @ a.T, inputs, adaptive=True, seed=2)
    covariance = a @ np.diag([0.01, 0.04, 0.09]) @ a.T
    report = validate_guf(
        a @ [1.0, 2.0, 3.0], covariance, mcm, tolerance=mcm.tolerance, names=["sum12", "sum23"]
    )
    assert report.passed, report.to_text()
    assert len(report.rows) == 6
    assert report.procedure == "JCGM 102:2011 §8"
    rows = {(row.name, row.quantity): row for row in report.rows}
    assert rows["all", "coverage factor"].guf == pytest.approx(2.4477, abs=1e-4)
    rho = 0.04 / np.sqrt(0.05 * 0.13)
    assert rows["all", "largest eigenvalue"].guf == pytest.approx(1 + rho)
    assert rows["sum23", "standard uncertainty"].guf == pytest.approx(np.sqrt(0.13))


def test_square_of_a_normal_is_not_validated_and_names_the_failing_rows():
    """Y = X², X ~ N(0, 1): the GUF linearisation gives y = 0, u = 0 (zero sensitivity),
    while the output is χ²_1 with the symmetric interval [0.001, 5.02]; d_high ≈ 5 ≫ δ."""
    mcm = monte_carlo(lambda x: x[:, 0] ** 2, normal_inputs([0.0], [1.0]), trials=100_000, seed=3)
    report = validate_guf(0.0, 0.0, mcm, tolerance=0.05)
    assert not report.passed
    assert [row.quantity for row in report.failed] == ["interval high"]
    assert report.failed[0].ratio > 50 and report.failed[0].name == "Y"
    assert report.to_dict()["passed"] is False


def test_polar_coordinates_of_jcgm102_9_3_are_not_validated():
    """JCGM 102 9.3 style: (X1, X2) ~ N((0.001, 0), 0.01² I) to polar (R, Φ). The GUF at the
    estimate gives u(R) = 0.01 and u(Φ) = 0.01/0.001 = 10 rad, while Φ lives in (−π, π]
    (u ≈ 1.8 rad) and R has mean ≈ 0.0125: estimate of R, u(Φ) and λ/k_p rows fail."""

    def polar(x):
        return np.column_stack([np.hypot(x[:, 0], x[:, 1]), np.arctan2(x[:, 1], x[:, 0])])

    mcm = monte_carlo(polar, normal_inputs([0.001, 0.0], [0.01, 0.01]), trials=200_000, seed=4)
    jacobian = np.array([[1.0, 0.0], [0.0, 1.0 / 0.001]])  # ∂(R, Φ)/∂(X1, X2) at (0.001, 0)
    covariance = jacobian @ np.diag([1e-4, 1e-4]) @ jacobian.T
    report = validate_guf(
        [0.001, 0.0],
        covariance,
        mcm,
        tolerance=NumericalTolerance([0.0005, 0.05], 0.05, 0.05),
        names=["R", "phi"],
    )
    assert not report.passed
    failed = {(row.name, row.quantity) for row in report.failed}
    assert ("R", "estimate") in failed
    assert ("phi", "standard uncertainty") in failed


def test_row_ratio_reproduces_sepahi_boroujeni_table_7_1():
    """Sepahi Boroujeni (2021), Table 7-1, X of point 1: d_y = 2.89e-5 mm against
    δ = 0.05 µm = 5e-5 mm -> 58 %; u of Z of point 2: d_u = 1.91e-2 µm against 0.05 µm -> 38 %."""
    row = ValidationRow("X1", "estimate", -178.6462, -178.6462 + 2.89e-5, 2.89e-5, 5e-5)
    assert round(100 * row.ratio) == 58 and row.passed
    row = ValidationRow("Z2", "standard uncertainty", 7.7, 7.7191, 1.91e-2, 0.05)
    assert round(100 * row.ratio) == 38


def test_default_rho_and_kappa_follow_two_digits_of_the_mcm_values():
    """Without a NumericalTolerance, ρ and κ_p are ½·10^l of λ_max and k_p to two digits
    (λ ≈ 1.6 and k_p ≈ 2.45 both give 0.05, the values of Sepahi Boroujeni 2021, Ch. 7)."""
    a = np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 1.0]])
    mcm = monte_carlo(lambda x: x @ a.T, normal_inputs([0, 0, 0], [1, 1, 1]), trials=50_000, seed=5)
    report = validate_guf([0.0, 0.0], a @ a.T, mcm, tolerance=0.05)
    tolerances = {row.quantity: row.tolerance for row in report.rows}
    assert tolerances["largest eigenvalue"] == pytest.approx(0.05)
    assert tolerances["coverage factor"] == pytest.approx(0.05)


def test_t_factor_and_explicit_interval_for_one_output():
    """GUF interval from a t-factor (finite ν_eff) or given directly."""
    inputs = normal_inputs([0.0], [1.0])
    mcm = monte_carlo(lambda x: x[:, 0], inputs, trials=200_000, seed=6)
    wide = validate_guf(0.0, 1.0, mcm, tolerance=0.05, guf_coverage_factor=2.57)  # t_95(5)
    assert not wide.passed  # 2.57 − 1.96 = 0.61 ≫ 0.05
    given = validate_guf(0.0, 1.0, mcm, tolerance=0.05, guf_interval=[-1.96, 1.96])
    assert given.passed


def test_report_renders_as_text_dict_and_rich_table():
    mcm = monte_carlo(lambda x: x[:, 0] ** 2, normal_inputs([0.0], [1.0]), trials=10_000, seed=7)
    report = validate_guf(0.0, 0.0, mcm, tolerance=0.05, names=["square"])
    text = report.to_text()
    assert "FAIL" in text and "square" in text and "interval high" in text
    assert str(report) == text
    document = json.loads(json.dumps(report.to_dict()))
    assert document["passed"] is False and document["rows"][1]["passed"] is False
    console = Console(record=True, width=120)
    console.print(report.to_rich())
    assert "interval high" in console.export_text()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"p": 0.99}, "differs from the p"),
        ({"p": 1.2}, "p must lie"),
        ({"tolerance": 0.0}, "positive"),
        ({"tolerance": None}, "tolerance is required"),
        ({"guf_estimate": [0.0, 1.0]}, "guf_estimate must have 1"),
        ({"guf_covariance": -1.0}, "non-negative"),
        ({"guf_estimate": np.nan}, "finite"),
        ({"names": ["a", "b"]}, "names has 2"),
        ({"guf_interval": [1.0, -1.0]}, "guf_interval"),
        ({"guf_coverage_factor": -2.0}, "guf_coverage_factor"),
    ],
)
def test_bad_input_is_refused(kwargs, match):
    mcm = monte_carlo(lambda x: x[:, 0], normal_inputs([0.0], [1.0]), trials=2_000, seed=8)
    arguments = {"guf_estimate": 0.0, "guf_covariance": 1.0, "tolerance": 0.05} | kwargs
    estimate = arguments.pop("guf_estimate")
    covariance = arguments.pop("guf_covariance")
    with pytest.raises(ValueError, match=match):
        validate_guf(estimate, covariance, mcm, **arguments)


def test_asymmetric_guf_covariance_is_refused():
    a = np.eye(2)
    mcm = monte_carlo(lambda x: x @ a, normal_inputs([0, 0], [1, 1]), trials=2_000, seed=9)
    with pytest.raises(ValueError, match="symmetric"):
        validate_guf([0, 0], [[1.0, 0.5], [0.2, 1.0]], mcm, tolerance=0.1)
