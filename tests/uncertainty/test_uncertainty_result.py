"""GUF and Monte Carlo results share one base: same fields, same meaning, same file-form part."""

import dataclasses

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.uncertainty.guf import GUFResult, guf
from mtmetrology.uncertainty.inputs import InputSet
from mtmetrology.uncertainty.mcm import MCMResult, monte_carlo
from mtmetrology.uncertainty.result import UncertaintyResult

A = np.array([[1.0, 2.0, 0.0], [0.0, 1.0, -1.0]])
INPUTS = InputSet.from_covariance(
    ["x0", "x1", "x2"], [1.0, 2.0, -1.0], np.diag([0.1, 0.2, 0.3]) ** 2
)
BASE_FIELDS = [f.name for f in dataclasses.fields(UncertaintyResult)]
BASE_KEYS = [
    "method",
    "outputs",
    "covariance",
    "correlation",
    "largest_eigenvalue",
    "region_coverage_factor",
    "rectangular_coverage_factor",
]


class Linear:
    """Y = A X: the GUF is exact and Monte Carlo agrees with it within its sampling noise."""

    output_names = ("a", "b")
    output_units = ("mm", "mm")

    def __call__(self, x):
        return x @ A.T


@pytest.fixture(scope="module")
def results():
    return guf(Linear(), INPUTS), monte_carlo(Linear(), INPUTS, trials=200_000, seed=12)


def test_both_results_are_uncertainty_results_with_the_base_fields_first(results):
    for result in results:
        assert isinstance(result, UncertaintyResult)
        assert [f.name for f in dataclasses.fields(result)][: len(BASE_FIELDS)] == BASE_FIELDS
    assert GUFResult.method == "guf" and MCMResult.method == "mcm"


def test_the_base_fields_mean_the_same_for_a_linear_model(results):
    """U_y = A U_x Aᵀ exactly for the GUF; M = 2·10⁵ trials give u(y) to a relative
    standard deviation of 1/√(2M) = 0.16 % and quantiles to about 0.3 %: tolerances
    are 2 %.  k_q: the GUF's Bonferroni 2.2414 against the sample's 2.2365 of two
    nearly independent outputs (Φ⁻¹((1 + √p)/2)), 0.2 % apart."""
    g, m = results
    cov = A @ np.diag([0.01, 0.04, 0.09]) @ A.T
    np.testing.assert_allclose(g.covariance, cov, rtol=1e-12)
    assert g.names == m.names == ("a", "b") and g.units == m.units == ("mm", "mm")
    assert g.p == m.p == 0.95
    np.testing.assert_allclose(m.estimate, g.estimate, atol=0.01)
    np.testing.assert_allclose(m.covariance, g.covariance, rtol=0.02, atol=1e-4)
    np.testing.assert_allclose(m.standard_uncertainty, g.standard_uncertainty, rtol=0.02)
    np.testing.assert_allclose(m.correlation, g.correlation, atol=0.01)
    assert m.largest_eigenvalue == pytest.approx(g.largest_eigenvalue, rel=0.02)
    assert m.region_coverage_factor == pytest.approx(g.region_coverage_factor, rel=0.02)
    assert m.rectangular_coverage_factor == pytest.approx(g.rectangular_coverage_factor, rel=0.02)
    np.testing.assert_allclose(m.interval, g.interval, atol=0.02)
    np.testing.assert_allclose(m.expanded_uncertainty, g.expanded_uncertainty, rtol=0.02)
    np.testing.assert_allclose(m.coverage_factor, g.coverage_factor, rtol=0.02)
    for result in results:  # U is half the interval and k = U/u in both
        half = 0.5 * (result.interval[:, 1] - result.interval[:, 0])
        np.testing.assert_allclose(result.expanded_uncertainty, half, rtol=1e-12)
        np.testing.assert_allclose(
            result.coverage_factor * result.standard_uncertainty, half, rtol=1e-12
        )
        assert result.output("b") == result.outputs[1] == result.output(-1)
        with pytest.raises(InputError, match="no output named 'c'"):
            result.output("c")


def test_each_file_form_holds_the_base_keys_in_its_unchanged_order(results):
    g, m = results
    guf_keys = list(g.to_dict())
    mcm_keys = list(m.to_dict())
    assert [k for k in guf_keys if k in BASE_KEYS] == BASE_KEYS
    assert [k for k in mcm_keys if k in BASE_KEYS] == BASE_KEYS
    # the layouts the examples' JSON pins (version 2 of the uncertainty result document)
    assert guf_keys == [
        "method", "outputs", "dof_effective", *BASE_KEYS[2:],
        "sensitivity_method", "newton_iterations", "budget",
    ]  # fmt: skip
    assert mcm_keys == [
        "method", "outputs", "interval_shortest", *BASE_KEYS[2:],
        "trials", "sequences", "converged", "criterion", "tolerance", "checks", "message",
    ]  # fmt: skip
    for result, document in ((g, g.to_dict()), (m, m.to_dict())):
        assert document["covariance"]["matrix"] == result.covariance.tolist()
        assert document["outputs"] == [o.to_dict() for o in result.outputs]
