"""Targeted tests that pin exact messages and fields left open by the mutation sample."""

import numpy as np
import pytest

from mtmetrology.uncertainty.distributions import Normal, make_distribution


def test_bounded_refuses_low_high_mixed_with_half_width():
    with pytest.raises(ValueError) as info:
        make_distribution("rectangular", low=0, high=1, a=0.5)
    assert str(info.value) == (
        "distribution 'rectangular' takes parameters (low, high) or (x, a); "
        "got ['a', 'high', 'low']"
    )


def test_bounded_refuses_centre_half_width_mixed_with_high():
    with pytest.raises(ValueError) as info:
        make_distribution("rectangular", x=0, a=1, high=2)
    assert str(info.value) == (
        "distribution 'rectangular' takes parameters (low, high) or (x, a); got ['a', 'high', 'x']"
    )


def test_normal_accepts_coverage_factor_below_one():
    assert make_distribution("normal", x=0.0, U=0.1, k=0.5).u == pytest.approx(0.2)


def test_welch_satterthwaite_correlated_finite_dof_message():
    from mtmetrology.uncertainty.guf import welch_satterthwaite

    with pytest.raises(Exception) as info:
        welch_satterthwaite(np.ones(2), [[1, 0.5], [0.5, 1]], [5, np.inf], names=["a", "b"])
    assert str(info.value) == (
        "inputs 'a' and 'b' are correlated and one has finite degrees of freedom (5, inf) "
        "outside a common ensemble; Welch–Satterthwaite (JCGM 100 G.4.1) then does not "
        "apply: declare them an ensemble (estimated from the same observations), give "
        "them infinite dof, or use Monte Carlo"
    )


def test_numerical_tolerance_non_finite_message():
    from mtmetrology.uncertainty.mcm import numerical_tolerance

    with pytest.raises(ValueError) as info:
        numerical_tolerance(float("nan"))
    assert str(info.value) == "cannot derive a tolerance from a non-finite value nan"


def test_guf_budget_rows_carry_contribution():
    from mtmetrology.uncertainty.guf import guf
    from mtmetrology.uncertainty.inputs import InputSet

    s = InputSet.from_observations(["a", "b"], [[1, 2], [1.1, 2.2], [0.9, 2.1]], ["m", "m"])
    rows = guf(lambda x: x[..., 0] + 2 * x[..., 1], s).to_dict()["budget"]["y"]
    assert [r["input"] for r in rows] == ["a", "b"]
    assert rows[0]["contribution"] == pytest.approx(0.1 / np.sqrt(3))
    assert rows[1]["contribution"] == pytest.approx(2 * 0.1 / np.sqrt(3))


def _sum_inputs():
    from mtmetrology.uncertainty.inputs import InputQuantity, InputSet

    return InputSet(
        [
            InputQuantity(n, Normal(x, u))
            for n, x, u in zip("abc", [1.0, 2.0, -1.0], [0.1, 0.2, 0.3], strict=True)
        ]
    )


PAIR = np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 1.0]])


def test_mcm_to_dict_tolerance_and_check_fields():
    from mtmetrology.uncertainty.mcm import monte_carlo

    r = monte_carlo(lambda x: x @ PAIR.T, _sum_inputs(), adaptive=True, digits=1, seed=23)
    d = r.to_dict()
    assert d["tolerance"] == {"output": [0.05, 0.05], "eigenvalue": 0.5, "coverage_factor": 0.5}
    assert [(c["quantity"], c["output"]) for c in d["checks"][:2]] == [
        ("estimate", 0),
        ("estimate", 1),
    ]
    assert (
        d["message"] == "converged after 2 sequences of 10000 trials (2·s/√h ≤ δ (JCGM 101 7.9.4))"
    )


def test_mcm_strict_rule_message_and_minimum_sequences():
    from mtmetrology.uncertainty.mcm import monte_carlo

    r = monte_carlo(
        lambda x: x.sum(axis=-1),
        _sum_inputs(),
        adaptive=True,
        digits=1,
        seed=22,
        criterion="strict",
    )
    assert r.sequences == 10
    assert r.message == "converged after 10 sequences of 10000 trials (s ≤ δ (strict))"


def test_mcm_fixed_message_plural_and_default_trials():
    from mtmetrology.uncertainty.mcm import monte_carlo

    r = monte_carlo(lambda x: x @ PAIR.T, _sum_inputs(), trials=1000, seed=23)
    assert r.message == "1000 trials, 2 outputs"
    r = monte_carlo(lambda x: x.sum(axis=-1), _sum_inputs(), seed=1)
    assert r.trials == 1_000_000
    assert r.message == "1000000 trials, 1 output (scalar model)"


def test_mcm_refuses_inputs_without_sample():
    from mtmetrology.uncertainty.mcm import monte_carlo

    with pytest.raises(TypeError) as info:
        monte_carlo(lambda x: x, object(), trials=10)
    assert str(info.value) == "inputs must have a sample(rng, size) -> (size, N) method"


def _unit_normal_mcm():
    from mtmetrology.uncertainty.inputs import InputSet
    from mtmetrology.uncertainty.mcm import monte_carlo

    inputs = InputSet.from_covariance(["x0"], [0.0], [[1.0]])
    return monte_carlo(lambda x: x[:, 0], inputs, trials=10_000, seed=3)


def test_validation_failed_message_text_and_rich_table():
    from rich.console import Console

    from mtmetrology.uncertainty.validation import validate_guf

    report = validate_guf(0.3, 1.0, _unit_normal_mcm(), tolerance=0.05)
    message = (
        "GUF not validated at p = 0.95: Y interval low (601 %), Y interval high (583 %) "
        "outside tolerance"
    )
    assert report.message == message
    assert report.to_text().splitlines() == [
        "output  quantity       GUF     MCM     |difference|  tolerance  ratio",
        "Y       interval low   -1.660  -1.961  0.301         0.05       601 %  FAIL",
        "Y       interval high  2.260   1.968   0.292         0.05       583 %  FAIL",
        message,
    ]
    table = report.to_rich()
    assert [c.header for c in table.columns] == [
        "output",
        "quantity",
        "GUF",
        "MCM",
        "|difference|",
        "tolerance",
        "ratio",
    ]
    console = Console(width=200, record=True)
    console.print(table)
    lines = console.export_text().splitlines()
    assert (
        "│ Y      │ interval low  │ -1.660 │ -1.961 │        0.301 │      0.05 │ 601 % │" in lines
    )


def test_validation_passing_rows_say_ok():
    from mtmetrology.uncertainty.validation import validate_guf

    report = validate_guf(0.0, 1.0, _unit_normal_mcm(), tolerance=0.5)
    assert report.to_text().splitlines()[1:3] == [
        "Y       interval low   -1.96  -1.96  0.00066       0.5        0 %    ok",
        "Y       interval high  1.96   1.97   0.0084        0.5        2 %    ok",
    ]


def test_result_document_source_and_output_names():
    from mtmetrology.uncertainty.guf import guf
    from mtmetrology.uncertainty.inputs import InputSet
    from mtmetrology.uncertainty.outputs import result_document

    inputs = InputSet.from_covariance(["x0"], [0.0], [[1.0]])
    g = guf(lambda x: x[..., 0], inputs, output_names=["s"], output_units=["µm"])
    document = result_document(g, model="m", source="f.yaml")
    assert document["model"] == "m" and document["source"] == "f.yaml"
    assert document["outputs"][0]["name"] == "s"
    assert g.outputs[0].name == "s"


@pytest.mark.parametrize("tail", [1, 2, 50, 250, 500, 6000, 7000])
def test_column_tails_are_the_exact_order_statistics(tail):
    from mtmetrology.uncertainty.regions import _column_tails

    values = np.random.default_rng(5).normal(size=10_000)
    ordered = np.sort(values)
    low, high, counts, edges = _column_tails(values, tail, None)
    assert np.array_equal(np.sort(low), ordered[:tail])
    assert np.array_equal(np.sort(high), ordered[10_000 - tail :])
    assert counts is None and edges is None


def test_intervals_and_histograms_default_has_100_bins():
    from mtmetrology.uncertainty.regions import intervals_and_histograms

    values = np.random.default_rng(5).normal(size=(10_000, 1))
    _, _, histograms = intervals_and_histograms(values)
    assert histograms[0].values.shape == (100,) and histograms[0].edges.shape == (101,)


def test_guf_names_the_non_finite_estimate():
    from types import SimpleNamespace

    from mtmetrology.uncertainty.guf import guf

    inputs = SimpleNamespace(
        estimate=np.array([1.0, np.nan]),
        covariance=np.eye(2),
        names=["a", "b"],
        units=["m", "m"],
        dof=np.array([np.inf, np.inf]),
        ensemble=None,
    )
    with pytest.raises(Exception) as info:
        guf(lambda x: x.sum(axis=-1), inputs)
    assert str(info.value) == "input estimates must be finite; NaN/inf for ['b']"


def test_sequence_statistics_largest_eigenvalue_of_three_outputs():
    from mtmetrology.uncertainty.stability import sequence_statistics

    values = np.random.default_rng(1).normal(size=(1000, 3))
    values[:, 1] += values[:, 0]
    stats = sequence_statistics(values, 0.95)
    assert stats.shape == (14,)
    assert stats[12] == pytest.approx(np.linalg.eigvalsh(np.corrcoef(values.T))[-1])


def test_evaluate_chunk_counts_are_integers_when_all_finite():
    from mtmetrology.uncertainty.chunks import _ChunkTask, _evaluate_chunk

    task = _ChunkTask(lambda x: x[:, 0], _sum_inputs(), np.random.default_rng(0), 8)
    out = _evaluate_chunk(task)
    assert out.bad_trials.dtype.kind == "i"
    assert out.bad_trials.tolist() == [0] and out.first_bad_input is None
