"""The coverage policy (issue 31): k = 2 by default, k or p from the user, and the check
that a result document states k beside every U with U = k u."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from mtmetrology.errors import InputError
from mtmetrology.uncertainty.coverage import (
    DEFAULT,
    DEFAULT_P,
    coverage_policy,
    unstated_coverage,
)


def test_default_is_k_2_with_the_normal_probability():
    """EA-4/02, ILAC-P14: k = 2; its normal coverage 2 Φ(2) − 1 = 0.9545 (GUM G.1.3)."""
    assert DEFAULT.k == 2.0 and coverage_policy() is DEFAULT
    assert DEFAULT_P == pytest.approx(2 * stats.norm.cdf(2.0) - 1, abs=1e-15)
    assert DEFAULT.expanded(np.array([1.0, 0.35])).tolist() == [2.0, 0.7]
    assert DEFAULT.label == "k = 2" and DEFAULT.to_dict()["coverage_probability"] == DEFAULT_P


@pytest.mark.parametrize(("p", "k"), [(0.95, 1.959964), (0.99, 2.575829), (0.6827, 1.000)])
def test_p_gives_the_normal_k_and_back(p, k):
    """JCGM 100:2008, Table G.1: p = 95 % -> 1.960, 99 % -> 2.576, 68.27 % -> 1."""
    policy = coverage_policy(p=p)
    assert policy.k == pytest.approx(k, abs=5e-4) and policy.stated == "p"
    assert coverage_policy(k=policy.k).p == pytest.approx(p, abs=1e-12)


@pytest.mark.parametrize(
    ("k", "p", "option"),
    [(2.0, 0.95, "--k and --p"), (0.0, None, "--k"), (float("nan"), None, "--k"),
     (float("inf"), None, "--k"), (-1.0, None, "--k"), (None, 1.0, "--p"), (None, 0.0, "--p"),
     (None, float("nan"), "--p")],
)  # fmt: skip
def test_bad_k_or_p_is_refused_naming_the_option(k, p, option):
    with pytest.raises(InputError, match=option):
        coverage_policy(k, p)


def test_unstated_coverage_finds_a_missing_k_and_a_wrong_u():
    good = {
        "coverage": {"k": 2.0},
        "parameters": [{"name": "a", "u": 1.5, "U": 3.0}],
        "outputs": [{"u": 0.5, "U": 0.98, "k": 1.96, "p": 0.95, "interval": [0.0, 1.96]}],
        "bipoints": {"U_um": [2.0, 3.0], "u_um": [1.0, 1.0], "k": [2.0, 3.0]},
        "U1_um": [0.3, 0.4],  # the source's name of a mean standard uncertainty: not a U
    }
    assert unstated_coverage(good) == []
    assert unstated_coverage({"rows": [{"U_um": 3.0, "u_um": 1.5}]}) == [
        "/rows[0]/U_um: U without its coverage factor k"
    ]
    wrong = unstated_coverage({"k": 2.0, "u": 1.5, "U": 2.94})  # 1.96 u labelled k = 2
    assert len(wrong) == 1 and wrong[0].startswith("/U: U = 2.94 is not k u")
    assert unstated_coverage({"interval": [0, 1]}) == [
        "/interval: an interval without its coverage probability"
    ]
