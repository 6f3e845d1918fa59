"""Generic datum choice by rank (identification.datum), on exact synthetic Jacobians."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.identification.datum import Datum, choose_datum


def _columns(seed=0, m=40):
    rng = np.random.default_rng(seed)
    return rng.normal(size=(m, 4)), rng.normal(size=(m, 2))


def test_keeps_independent_drops_combinations_and_names_partners():
    a, nu = _columns()
    # E_XX3 = 2·E_XX1 − E_YY1; E_ZZ2 in the span of the nuisance; E_AX1 zero (not seen)
    jac = np.column_stack([a[:, 0], a[:, 1], 2 * a[:, 0] - a[:, 1], nu[:, 0] + nu[:, 1],
                           np.zeros(len(a)), nu])  # fmt: skip
    names = ["E_XX1", "E_YY1", "E_XX3", "E_ZZ2", "E_AX1"]
    d = choose_datum(jac, names, nuisance=["D", "L"])
    assert d.kept == ("E_XX1", "E_YY1")
    assert dict(d.dropped) == {
        "E_XX3": ("E_XX1", "E_YY1"),
        "E_ZZ2": ("D", "L"),
        "E_AX1": (),
    }
    assert (d.rank, d.n_unknowns) == (4, 7)
    assert d.rank == np.linalg.matrix_rank(jac)
    assert Datum.from_dict(d.to_dict()) == d


def test_lower_degree_kept_before_higher_and_prefer_overrides():
    a, _ = _columns(1)
    jac = np.column_stack([a[:, 0], a[:, 0] * 3.0])
    assert choose_datum(jac, ["E_ZZ3", "E_ZZ1"]).kept == ("E_ZZ1",)
    assert choose_datum(jac, ["E_ZZ3", "E_ZZ1"], prefer=["E_ZZ3"]).kept == ("E_ZZ3",)


def test_full_rank_keeps_all_and_says_so():
    a, nu = _columns(2)
    d = choose_datum(
        np.column_stack([a, nu]), ["E_XX1", "E_XX2", "E_YY1", "E_C0Y"], nuisance=["D", "L"]
    )
    assert d.dropped == () and d.message == "rank 6 of 6: every parameter is identifiable"


def test_wrong_shape_refused():
    with pytest.raises(ValueError, match="expected"):
        choose_datum(np.zeros((5, 3)), ["E_XX1"], nuisance=["D"])


def test_constant_rotation_candidates_nearest_the_tool_first_without_those_in_the_model():
    from mtmetrology.identification.datum import constant_rotation_candidates
    from mtmetrology.kinematics import Machine

    three = Machine.load("three-axis-xfyz")
    assert constant_rotation_candidates(three) == (
        "E_AZ0", "E_BZ0", "E_CZ0", "E_AY0", "E_BY0", "E_CY0",
    )  # fmt: skip
    with_yaw = three.with_parameters([*three.parameter_names, "E_CZ0"])
    assert "E_CZ0" not in constant_rotation_candidates(with_yaw)
    five = Machine.load("five-axis-wcbxfzyst")  # tool branch Z, Y, S: the spindle first
    assert constant_rotation_candidates(five)[:3] == ("E_AS0", "E_BS0", "E_CS0")


def test_exposed_terms_adds_what_leaves_the_span_and_names_what_absorbs_the_rest():
    """A machine with one parameter and one nuisance unknown; three candidate constants with
    columns c1 = a + 2·ν (absorbed by a and ν), c2 independent (added), c3 = c2 (absorbed by
    the candidate added before it)."""
    from mtmetrology.identification.datum import SetupTerms, exposed_terms
    from mtmetrology.kinematics import Machine

    m = Machine.load("three-axis-xfyz").with_parameters(["E_XX1"])
    a, nu, c2 = np.eye(4)[:, 0], np.eye(4)[:, 1], np.eye(4)[:, 2]

    def jacobian_of(big):
        assert big.parameter_names == ("E_XX1", "E_AZ0", "E_BZ0", "E_CZ0")
        return np.column_stack([a, a + 2 * nu, c2, c2, nu])

    terms = exposed_terms(jacobian_of, m, ["nu"], candidates=["E_AZ0", "E_BZ0", "E_CZ0"])
    assert terms.added == ("E_BZ0",)
    assert terms.absorbed == (("E_AZ0", ("E_XX1", "nu")), ("E_CZ0", ("E_BZ0",)))
    assert SetupTerms.from_dict(terms.to_dict()) == terms
    assert terms.to_dict()["added"] == ["E_BZ0"]
