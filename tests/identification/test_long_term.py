"""Tests for mtmetrology.identification.long_term (Sepahi Boroujeni (2021), §5.3)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from mtmetrology.errors import InputError
from mtmetrology.identification.long_term import long_term_parameters
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

MACHINE = Machine.load("five-axis-wcbxfzyst")
SCALES = MACHINE.parameter_scales  # 1 µm, 1 µrad, 1 µm/m in internal units
_A = np.random.default_rng(11).normal(size=(13, 13))
SIGMA = (_A @ _A.T / 13 + np.eye(13)) * np.outer(SCALES, SCALES)  # correlated, ~1.4 units
MEAN = np.random.default_rng(12).normal(size=13) * SCALES * 20


def _sets(values, covariance=None, names=MACHINE.parameter_names, **kw):
    return [
        ParameterSet(names, np.asarray(v), MACHINE.parameter_units, covariance, **kw)
        for v in values
    ]


def test_sample_covariance_is_unbiased_wishart_mean():
    """200 campaigns of K = 15 days drawn from N(μ, Σ): (K − 1) tr(Σ⁻¹ Σ̂) is χ²(P(K − 1))
    for each campaign, so the sum over campaigns is χ²(200·13·14 = 36 400); it must lie in
    the two-sided 99.9 % interval. An n (not n − 1) divisor shifts it by 2 427, 9 standard
    deviations. Every entry of the mean Σ̂ must also be within 4.5 Wishart standard errors
    (Var Σ̂_ij = (Σ_ij² + Σ_ii Σ_jj)/(K − 1)/200; Bonferroni over 91 entries: 0.06 % false
    alarm)."""
    rng = np.random.default_rng(2021)
    campaigns, days, p = 200, 15, 13
    draws = rng.multivariate_normal(MEAN, SIGMA, (campaigns, days))
    estimates = np.stack([long_term_parameters(_sets(d, machine="m")).covariance for d in draws])
    inv = np.linalg.inv(SIGMA)
    statistic = (days - 1) * np.einsum("ij,cji->", inv, estimates)
    dof = campaigns * p * (days - 1)
    low, high = stats.chi2.ppf([0.0005, 0.9995], dof)
    assert low <= statistic <= high
    se = np.sqrt((SIGMA**2 + np.outer(np.diag(SIGMA), np.diag(SIGMA))) / (days - 1) / campaigns)
    z = (estimates.mean(axis=0) - SIGMA) / se
    assert np.abs(z[np.triu_indices(p)]).max() < 4.5


def test_values_latest_or_mean_and_covariance_equals_numpy_cov():
    rng = np.random.default_rng(3)
    values = rng.multivariate_normal(MEAN, SIGMA, 5)
    latest = long_term_parameters(_sets(values, machine="m", model="13"))
    mean = long_term_parameters(_sets(values, machine="m", model="13"), values="mean")
    assert np.array_equal(latest.values, values[-1])
    assert np.allclose(mean.values, values.mean(axis=0), rtol=0, atol=1e-15)
    assert np.allclose(latest.covariance, np.cov(values.T, ddof=1), rtol=1e-12, atol=0)
    assert latest.machine == "m" and latest.model == "13"
    assert latest.names == MACHINE.parameter_names and latest.units == MACHINE.parameter_units
    prov = latest.provenance
    assert prov["calibrations"] == 5 and prov["rank"] == 4  # K − 1 < P: singular Σ
    assert prov["values"] == "latest" and prov["within_calibration_covariance_added"] is False


def test_parameter_order_of_each_set_does_not_matter():
    rng = np.random.default_rng(4)
    values = rng.multivariate_normal(MEAN, SIGMA, 4)
    perm = rng.permutation(13)
    names = tuple(MACHINE.parameter_names[i] for i in perm)
    mixed = _sets(values[:2], machine="m") + _sets(values[2:, perm], names=names, machine="m")
    ref = long_term_parameters(_sets(values, machine="m"))
    got = long_term_parameters(mixed)
    assert got.names == ref.names
    assert np.allclose(got.covariance, ref.covariance, rtol=1e-12, atol=0)
    assert np.array_equal(got.values, ref.values)  # the latest set, put back in order


def test_add_within_adds_the_mean_calibration_covariance():
    rng = np.random.default_rng(5)
    values = rng.multivariate_normal(MEAN, SIGMA, 3)
    sets = [
        ParameterSet(
            MACHINE.parameter_names, v, MACHINE.parameter_units, SIGMA * (k + 1), machine="m"
        )
        for k, v in enumerate(values)
    ]
    plain = long_term_parameters(sets)
    within = long_term_parameters(sets, add_within=True)
    assert np.allclose(within.covariance - plain.covariance, 2 * SIGMA, rtol=1e-12, atol=0)
    assert within.provenance["rank"] == 13


@pytest.mark.parametrize(
    ("kwargs", "culprit"),
    [
        ({"values": "median"}, "values"),
        ({"add_within": True}, r"cal2\.json"),
    ],
)
def test_bad_options_are_refused_naming_the_culprit(kwargs, culprit):
    rng = np.random.default_rng(6)
    sets = _sets(rng.multivariate_normal(MEAN, SIGMA, 2), machine="m")
    sets[0] = ParameterSet(sets[0].names, sets[0].values, sets[0].units, SIGMA, machine="m")
    with pytest.raises(InputError, match=culprit):
        long_term_parameters(sets, sources=["cal1.json", "cal2.json"], **kwargs)


def test_fewer_than_two_or_mismatched_calibrations_are_refused():
    v = np.zeros(13)
    (one,) = _sets([v], machine="m")
    with pytest.raises(InputError, match="at least 2"):
        long_term_parameters([one])
    (other,) = _sets([v], machine="other")
    with pytest.raises(InputError, match=r"b\.json"):
        long_term_parameters([one, other], sources=["a.json", "b.json"])
    (model,) = _sets([v], machine="m", model="84")
    with pytest.raises(InputError, match=r"b\.json"):
        long_term_parameters([one, model], sources=["a.json", "b.json"])
    names = (*MACHINE.parameter_names[:12], "E_Z0S")
    (renamed,) = _sets([v], names=names, machine="m")
    with pytest.raises(InputError, match="E_Z0S"):
        long_term_parameters([one, renamed], sources=["a.json", "b.json"])
