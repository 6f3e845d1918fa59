"""Tests for mtmetrology.history.analysis: control chart and long-term covariance."""

from __future__ import annotations

from datetime import datetime, timedelta

import numpy as np
import pytest
from scipy import stats

from mtmetrology.errors import InputError
from mtmetrology.history import (
    TrendResult,
    add_result,
    long_term_covariance,
    open_history,
    parameter_trend,
    parameter_trends,
)
from mtmetrology.identification.long_term import long_term_parameters
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

MACHINE = Machine.load("five-axis-wcbxfzyst")
F = MACHINE.parameter_scales
START = datetime(2026, 1, 1, 7, 0)


def _record(engine, rows, make_calibration):
    for k, row in enumerate(rows):
        add_result(
            engine,
            make_calibration(row),
            MACHINE,
            performed_at=START + timedelta(days=k),
            by="test",
        )


def _whitened(sample_cov, sigma, k):
    """W = (K − 1) L⁻¹ S L⁻ᵀ ~ Wishart(I, K − 1) when S estimates Σ = L Lᵀ."""
    inv = np.linalg.inv(np.linalg.cholesky(sigma))
    return (k - 1) * inv @ sample_cov @ inv.T


def test_long_term_covariance_of_simulated_calibrations_recovers_the_known_one(
    history_url, make_calibration
):
    """K = 40 calibrations drawn from N(δ, Σ) with a known full Σ (µm, µrad, µm/m).

    With W = (K − 1) L⁻¹ S L⁻ᵀ ~ Wishart(I, K − 1): tr W ~ χ²(P(K − 1)) exactly, and the
    off-diagonal W_ij/√(K − 1) are uncorrelated with unit variance, Σ_{i<j} W_ij²/(K − 1)
    ≈ χ²(P(P − 1)/2). Each is accepted between its 0.05 % and 99.95 % quantiles (false
    rejection 0.2 % for the pair); the same statistics reject 1.5 Σ.
    """
    rng = np.random.default_rng(24)
    p, k = 13, 40
    a = rng.normal(size=(p, p))
    sigma = a @ a.T / p + np.eye(p) * 0.5  # customary units squared
    rows = rng.multivariate_normal(np.linspace(-3, 3, p), sigma, size=k)
    engine = open_history(history_url)
    _record(engine, rows, make_calibration)
    result = long_term_covariance(engine, MACHINE.name)
    estimate = result.covariance / np.outer(F, F)
    np.testing.assert_allclose(estimate, np.cov(rows, rowvar=False), rtol=1e-9, atol=1e-12)

    def accepted(reference):
        w = _whitened(estimate, reference, k)
        off = w[np.triu_indices(p, 1)] ** 2 / (k - 1)
        return all(
            stats.chi2.ppf(0.0005, dof) <= value <= stats.chi2.ppf(0.9995, dof)
            for value, dof in ((np.trace(w), p * (k - 1)), (off.sum(), p * (p - 1) // 2))
        )

    assert accepted(sigma)
    assert not accepted(1.5 * sigma)
    assert result.provenance["history"]["runs"] == k
    np.testing.assert_allclose(result.values / F, rows[-1], rtol=1e-12)


def test_history_covariance_is_the_long_term_statistic_on_files(
    history_url, make_calibration, tmp_path
):
    """One implementation: the database's covariance equals ``mtm samba long-term``'s
    function on the same calibrations, and its file is read back as a parameter set with
    the machine, model and covariance ``mtm task uncertainty --params`` needs."""
    rows = np.random.default_rng(5).normal(size=(6, 13))
    engine = open_history(history_url)
    _record(engine, rows, make_calibration)
    from_db = long_term_covariance(engine, MACHINE.name, values="mean")
    sets = [ParameterSet.from_document(make_calibration(r), MACHINE) for r in rows]
    from_files = long_term_parameters(sets, values="mean")
    np.testing.assert_allclose(from_db.covariance, from_files.covariance, rtol=1e-12)
    np.testing.assert_allclose(from_db.values, from_files.values, rtol=1e-12)
    path = tmp_path / "COV.json"
    from_db.save(path)
    loaded = ParameterSet.load(path, MACHINE)
    assert (loaded.machine, loaded.model) == (MACHINE.name, "13")
    np.testing.assert_allclose(loaded.covariance, from_db.covariance, rtol=1e-12)
    assert loaded.machine_for(MACHINE).parameter_names == MACHINE.parameter_names
    since = long_term_covariance(engine, MACHINE.name, since=START + timedelta(days=3))
    np.testing.assert_allclose(since.covariance / np.outer(F, F), np.cov(rows[3:], rowvar=False))


def test_control_chart_limits_in_closed_form_and_the_crash_flagged(history_url, make_calibration):
    """E_X0C = 0, 2, 1, 3 then 10 µm, limits from the first 4 runs: x̄ = 1.5, MR̄ = 5/3,
    σ̂ = MR̄/(2/√π); only the last run lies beyond x̄ + 3σ̂ ≈ 5.93 µm."""
    j = MACHINE.parameter_names.index("E_X0C")
    rows = np.zeros((5, 13))
    rows[:, j] = [0.0, 2.0, 1.0, 3.0, 10.0]
    engine = open_history(history_url)
    _record(engine, rows, make_calibration)
    trend = parameter_trend(engine, MACHINE.name, "E_X0C", baseline=4)
    sigma = (5 / 3) * np.sqrt(np.pi) / 2
    assert trend.unit == "µm"
    assert trend.centre == pytest.approx(1.5, rel=1e-12)
    assert trend.sigma == pytest.approx(sigma, rel=1e-12)
    assert trend.upper_limit == pytest.approx(1.5 + 3 * sigma, rel=1e-12)
    assert trend.lower_limit == pytest.approx(1.5 - 3 * sigma, rel=1e-12)
    assert trend.out_of_control.tolist() == [False, False, False, False, True]
    back = TrendResult.from_dict(trend.to_dict())
    assert back.to_dict() == trend.to_dict()
    with pytest.raises(InputError, match="parameter 'E_Q0Q': not a parameter"):
        parameter_trend(engine, MACHINE.name, "E_Q0Q")
    with pytest.raises(InputError, match="--baseline 1"):
        parameter_trend(engine, MACHINE.name, "E_X0C", baseline=1)


def test_every_parameters_chart_from_one_read_equals_the_chart_of_each(
    history_url, make_calibration
):
    """parameter_trends (one row a run, the stored vectors) gives the same chart as
    parameter_trend (the parameter's own rows) for every parameter, with a baseline and
    a date filter; a machine without runs is refused."""
    rows = np.random.default_rng(34).normal(size=(12, 13)) * 3.0
    rows[-1, 0] += 40.0  # one point out of control
    engine = open_history(history_url)
    _record(engine, rows, make_calibration)
    for options in ({}, {"baseline": 8}, {"since": START + timedelta(days=2)}):
        every = parameter_trends(engine, MACHINE.name, **options)
        assert list(every) == list(MACHINE.parameter_names)
        for name, chart in every.items():
            alone = parameter_trend(engine, MACHINE.name, name, **options)
            assert chart.to_dict() == alone.to_dict()
    assert every[MACHINE.parameter_names[0]].out_of_control[-1]
    with pytest.raises(InputError, match="'nowhere'"):
        parameter_trends(engine, "nowhere")


def test_add_within_adds_the_mean_of_the_runs_own_covariances(history_url, make_calibration):
    """With ``add_within`` the result is the scatter plus the mean of the recorded runs'
    covariances (here u = 0.5 µm, µrad, µm/m for every parameter: + 0.25 on the
    diagonal), as :func:`long_term_parameters` computes it on the files."""
    rows = np.random.default_rng(11).normal(size=(4, 13))
    engine = open_history(history_url)
    _record(engine, rows, make_calibration)
    plain = long_term_covariance(engine, MACHINE.name)
    within = long_term_covariance(engine, MACHINE.name, add_within=True)
    np.testing.assert_allclose(
        (within.covariance - plain.covariance) / np.outer(F, F), 0.25 * np.eye(13), atol=1e-12
    )
    sets = [ParameterSet.from_document(make_calibration(r), MACHINE) for r in rows]
    files = long_term_parameters(sets, add_within=True)
    np.testing.assert_allclose(within.covariance, files.covariance, rtol=1e-12)


def test_pattern_tests_fire_on_a_shift_and_a_trend_and_not_on_alternation():
    from mtmetrology.history.analysis import pattern_tests

    alternating = np.tile([1.0, -1.0], 10)
    assert [t.tolist() for t in pattern_tests(alternating, 0.0).values()] == [[], []]
    shifted = np.concatenate([np.tile([1.0, -1.0], 2), np.full(10, 2.0)])
    assert pattern_tests(shifted, 0.0)["run"].tolist() == [12, 13]  # 9 in a row: 4..12, 5..13
    assert pattern_tests(shifted, 0.0)["trend"].tolist() == []
    rising = np.array([0.0, 1, 2, 3, 4, 5, 4])
    assert pattern_tests(rising, 10.0)["trend"].tolist() == [5]
    on_the_line = np.array([1.0] * 4 + [0.0] + [1.0] * 4)  # a point on the centre breaks it
    assert pattern_tests(on_the_line, 0.0)["run"].tolist() == []


def test_the_chart_of_a_drifting_machine_points_to_history_drift(history_url, make_calibration):
    """32 calibrations drifting 0.3 µm a run (noise 0.5 µm): the chart flags points out of
    control and the run test fires (9 in a row on one side), so the document carries the
    hint to the drift model; a stable machine's chart carries none."""
    rng = np.random.default_rng(32)
    j = MACHINE.parameter_names.index("E_X0C")
    rows = np.zeros((32, 13))
    rows[:, j] = 0.3 * np.arange(32) + rng.normal(0.0, 0.5, 32)
    engine = open_history(history_url)
    _record(engine, rows, make_calibration)
    result = parameter_trend(engine, MACHINE.name, "E_X0C")
    assert result.out_of_control.any()
    assert result.special_causes["run"][0] == result.run_ids[8]  # the first 9 are below
    document = result.to_dict()
    assert document["hint"]["command"] == f"mtm history drift E_X0C --machine {MACHINE.name}"
    assert TrendResult.from_dict(document).special_causes == result.special_causes
    stable = parameter_trend(engine, MACHINE.name, "E_X0S")  # all zero: no sign, no run
    assert stable.hint() is None and stable.to_dict()["hint"] is None
