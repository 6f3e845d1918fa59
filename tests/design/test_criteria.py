"""Design criteria: definitions on known spectra, scaling conventions, UPF."""

import numpy as np
import pytest

from mtmetrology.design.choices import CRITERIA
from mtmetrology.design.criteria import (
    check_criterion,
    criterion_from_spectrum,
    scaled_spectrum,
    uncertainty_propagation_factors,
)
from mtmetrology.errors import InputError, RankDeficientError
from mtmetrology.identification import analyse_identifiability


def test_scaled_spectrum_is_the_squared_singular_values_of_unit_norm_columns():
    rng = np.random.default_rng(3)
    j = rng.standard_normal((40, 6)) * np.array([1e-3, 1.0, 50.0, 2.0, 1e4, 0.1])
    s = np.linalg.svd(j / np.linalg.norm(j, axis=0), compute_uv=False)
    np.testing.assert_allclose(scaled_spectrum(j.T @ j), np.sort(s**2), rtol=1e-10)


def test_observability_criteria_match_the_identification_diagnostics():
    """O1-O5 of a design equal those `analyse_identifiability` reports (one formula)."""
    rng = np.random.default_rng(4)
    j = rng.standard_normal((30, 5)) * np.array([1.0, 10.0, 0.1, 3.0, 7.0])
    rep = analyse_identifiability(j, list("abcde"), n_measurements=10)
    lam = scaled_spectrum(j.T @ j)
    for key, expected in rep.observability.items():
        assert float(criterion_from_spectrum(key, lam, 10)) == pytest.approx(expected, rel=1e-10)


def test_classical_criteria_on_a_known_spectrum():
    lam = np.array([0.5, 2.0, 8.0])
    assert float(criterion_from_spectrum("D", lam)) == pytest.approx(np.log(8.0))
    assert float(criterion_from_spectrum("A", lam)) == pytest.approx(-(2 + 0.5 + 0.125))
    assert float(criterion_from_spectrum("E", lam)) == 0.5
    assert float(criterion_from_spectrum("O4", lam)) == pytest.approx(0.5 / np.sqrt(8.0))


@pytest.mark.parametrize("name", CRITERIA)
def test_rank_deficient_spectrum_has_no_value(name):
    assert criterion_from_spectrum(name, np.array([0.0, 1.0, 2.0])) == -np.inf


def test_unknown_criterion_names_the_choices():
    with pytest.raises(InputError) as err:
        check_criterion("G")
    assert "O2" in str(err.value) and "'G'" in str(err.value)


def test_upf_is_the_root_diagonal_of_the_inverse_information():
    """Alami Mchichi (2018) eq. 6.14, against a direct inverse."""
    rng = np.random.default_rng(5)
    j = rng.standard_normal((20, 4)) * np.array([1e-3, 1.0, 1e3, 5.0])
    expected = np.sqrt(np.diag(np.linalg.inv(j.T @ j)))
    np.testing.assert_allclose(uncertainty_propagation_factors(j), expected, rtol=1e-9)
    with pytest.raises(RankDeficientError, match="no propagation factor"):
        uncertainty_propagation_factors(np.column_stack([j[:, 0], j[:, 0]]))
