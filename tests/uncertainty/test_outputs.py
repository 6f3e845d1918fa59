"""One vocabulary for every method: the same Output fields, the same joint names, one
result document; and the laws that tie the methods together (property tests)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mtmetrology.uncertainty import (
    InputQuantity,
    InputSet,
    Normal,
    Output,
    Rectangular,
    guf,
    monte_carlo,
    result_document,
    validate_results,
)
from mtmetrology.uncertainty.outputs import RESULT_KIND

OUTPUT_FIELDS = ("name", "value", "unit", "u", "U", "k", "p", "interval")
JOINT_FIELDS = (
    "covariance",
    "correlation",
    "largest_eigenvalue",
    "region_coverage_factor",
    "rectangular_coverage_factor",
)


def _two_lengths():
    """s = a + b and d = a − b for a = 10 ± 0.3 µm, b = 5 ± 0.4 µm: u(s) = u(d) = 0.5 µm."""
    inputs = InputSet(
        [InputQuantity("a", Normal(10.0, 0.3), "µm"), InputQuantity("b", Normal(5.0, 0.4), "µm")]
    )

    def model(x):
        return np.stack([x[..., 0] + x[..., 1], x[..., 0] - x[..., 1]], axis=-1)

    return model, inputs


RUN = {
    "guf": lambda model, inputs, **kw: guf(model, inputs, **kw),
    "mcm": lambda model, inputs, **kw: monte_carlo(model, inputs, trials=200_000, seed=5, **kw),
}


@pytest.mark.parametrize("method", ["guf", "mcm"])
def test_every_method_reports_the_same_output_fields(method):
    """Same names, units, Output records and joint quantities for GUF and Monte Carlo; the
    values are those of the exact answer (u = 0.5 µm, ρ(s, d) = (0.09 − 0.16)/0.25 = −0.28;
    M = 2·10⁵: u within 1 %, ≈ 6 standard errors)."""
    model, inputs = _two_lengths()
    result = RUN[method](model, inputs, output_names=["s", "d"], output_units=["µm", "µm"])
    assert result.method == method
    assert result.names == ("s", "d") and result.units == ("µm", "µm")
    assert all(isinstance(o, Output) for o in result.outputs)
    document = json.loads(json.dumps(result.to_dict(), allow_nan=False))
    assert document["method"] == method
    for entry, output in zip(document["outputs"], result.outputs, strict=True):
        assert tuple(entry) == OUTPUT_FIELDS
        assert entry == output.to_dict()
        assert entry["unit"] == "µm" and entry["p"] == 0.95
        assert entry["u"] == pytest.approx(0.5, rel=0.01)
        assert entry["U"] == pytest.approx(entry["k"] * entry["u"], rel=1e-12)
        low, high = entry["interval"]
        assert high - low == pytest.approx(2 * entry["U"], rel=1e-12)
        assert low < entry["value"] < high
    for name in JOINT_FIELDS:
        assert name in document
    assert document["covariance"]["names"] == ["s", "d"]
    assert document["covariance"]["units"] == ["µm", "µm"]
    assert result.correlation[0, 1] == pytest.approx(-0.28, abs=0.01)
    assert result.output("d") == result.outputs[1]
    with pytest.raises(ValueError, match="no output named 'x'"):
        result.output("x")


def test_result_document_of_both_methods():
    model, inputs = _two_lengths()
    g = guf(model, inputs, output_names=["s", "d"], output_units=["µm", "µm"])
    r = monte_carlo(model, inputs, trials=100_000, seed=3, output_names=["s", "d"],
                    output_units=["µm", "µm"])  # fmt: skip
    report = validate_results(g, r, digits=1)
    document = json.loads(json.dumps(result_document(g, r, report, model="two lengths")))
    assert document["kind"] == RESULT_KIND and document["method"] == "both"
    assert document["outputs"] == document["mcm"]["outputs"]
    assert document["validation"]["passed"] is report.passed is True
    alone = result_document(g)
    assert alone["method"] == "guf" and "validation" not in alone and "mcm" not in alone
    with pytest.raises(ValueError, match="both"):
        result_document(g, None, report)
    other = guf(model, inputs, p=0.99, output_names=["s", "d"])
    with pytest.raises(ValueError, match="differ"):
        result_document(other, r)
    with pytest.raises(ValueError, match="differ"):
        validate_results(other, r)


# --------------------------------------------------------------------------- property tests


class _ShuffledExecutor:
    """Runs the chunks in a random order, as any number of workers might finish them."""

    def __init__(self, workers: int, order_seed: int):
        self.workers = workers
        self._rng = np.random.default_rng(order_seed)

    def map(self, function, tasks):
        order = self._rng.permutation(len(tasks))
        done = {int(i): function(tasks[i]) for i in order}
        return [done[i] for i in range(len(tasks))]

    def close(self):
        pass


RECTANGULAR_PRODUCT = InputSet(
    [InputQuantity("a", Rectangular(1.0, 2.0)), InputQuantity("b", Normal(3.0, 0.2))]
)


def _product(x):
    return np.stack([x[:, 0] * x[:, 1], x[:, 0] / x[:, 1]], axis=-1)


@settings(max_examples=15, deadline=None)
@given(st.integers(1, 8), st.integers(0, 2**16), st.booleans())
def test_results_do_not_depend_on_workers_or_completion_order(workers, order_seed, adaptive):
    """Streams are drawn per chunk from one SeedSequence (never per worker), and adaptive
    sequences are tested in order, so any worker count and completion order gives the
    bit-identical result of the in-process run."""
    options = (
        {"adaptive": True, "sequence_size": 2_000, "digits": 1, "chunk_size": 700}
        if adaptive
        else {"trials": 5_000, "chunk_size": 1_300}
    )
    reference = monte_carlo(_product, RECTANGULAR_PRODUCT, seed=77, **options)
    shuffled = monte_carlo(
        _product, RECTANGULAR_PRODUCT, seed=77, executor=_ShuffledExecutor(workers, order_seed),
        **options,
    )  # fmt: skip
    assert shuffled.trials == reference.trials
    for name in ("estimate", "covariance", "interval", "interval_shortest"):
        np.testing.assert_array_equal(getattr(shuffled, name), getattr(reference, name))
    assert shuffled.region_coverage_factor == reference.region_coverage_factor
