"""Identifiability report on Jacobians with known structure."""

import numpy as np
import pytest

from mtmetrology.identification import analyse_identifiability


def test_two_identical_columns_are_named_as_confounded():
    rng = np.random.default_rng(0)
    j = rng.standard_normal((20, 4))
    j[:, 2] = -3.0 * j[:, 0]  # c ~ a, opposite effect, other scale
    rep = analyse_identifiability(j, ["a", "b", "c", "d"])
    assert rep.rank == 3 and not rep.full_rank
    assert rep.confounded() == [("a", "c")]
    assert str(rep.null_directions[0]) == "a ~ c"
    # in column-scaled coordinates the null vector is (1, 1)/√2: equal shares
    coefs = dict(rep.null_directions[0].terms)
    assert coefs["a"] == pytest.approx(coefs["c"])
    assert rep.message == "rank 3 of 4: a ~ c"
    assert rep.condition_scaled == float("inf")


def test_zero_column_is_reported_not_observable():
    j = np.eye(5, 3)
    j[:, 1] = 0.0
    rep = analyse_identifiability(j, ["p", "q", "r"])
    assert str(rep.null_directions[0]) == "q (not observable)"


def test_observability_indices_follow_their_definitions():
    """Alami Mchichi (2018), eqs 5.9-5.13, on a Jacobian with known singular values
    (unit-norm columns)."""
    s = np.array([4.0, 2.0, 1.0])
    u, _ = np.linalg.qr(np.random.default_rng(1).standard_normal((12, 3)))
    j = u * s  # orthogonal columns of norms 4, 2, 1 -> scaled singular values are all 1
    rep = analyse_identifiability(j, ["a", "b", "c"], n_measurements=4)
    np.testing.assert_allclose(rep.singular_values, 1.0)
    assert rep.condition_scaled == pytest.approx(1.0)
    assert rep.condition_raw == pytest.approx(4.0)
    o = rep.observability
    assert o["O2"] == pytest.approx(1.0 / rep.condition_scaled)
    assert o["O4"] == pytest.approx(o["O2"] * o["O3"])
    assert o["O1"] == pytest.approx(1.0 / np.sqrt(4))
    assert o["O5"] == pytest.approx(1.0 / 3.0)


def test_bad_jacobians():
    with pytest.raises(ValueError, match="must be"):
        analyse_identifiability(np.zeros((3, 2)), ["a"])
    with pytest.raises(ValueError, match="NaN"):
        analyse_identifiability(np.full((3, 1), np.nan), ["a"])
