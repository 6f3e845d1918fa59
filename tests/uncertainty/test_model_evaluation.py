"""evaluate_model: the GUF, Monte Carlo and validation of a model file, as one result."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mtmetrology.errors import InputError, ResourceLimitError
from mtmetrology.uncertainty.evaluation import MAX_VALUES, ModelEvaluation, evaluate_model
from mtmetrology.uncertainty.guf import guf
from mtmetrology.uncertainty.mcm import monte_carlo
from mtmetrology.uncertainty.modelfile import load_model
from mtmetrology.uncertainty.outputs import result_document
from mtmetrology.uncertainty.validation import validate_results

GUM_H1 = Path(__file__).resolve().parents[2] / "examples" / "gum-h1-end-gauge.yaml"


@pytest.fixture(scope="module")
def h1():
    return load_model(GUM_H1)


def test_guf_alone_gives_the_annex_uncertainty(h1):
    """JCGM 100:2008, H.1.4: u_c(l) = 32 nm (the model file is in nm)."""
    e = evaluate_model(h1, "guf")
    assert e.mcm is None and e.validation is None
    assert round(float(e.guf.standard_uncertainty[0])) == 32
    assert e.to_dict()["method"] == "guf"


def test_both_equals_the_methods_run_one_by_one(h1):
    """The document is result_document of guf, monte_carlo (same seed) and their validation."""
    e = evaluate_model(h1, "both", trials=5000, seed=7, p=0.99, source="h1.yaml")
    g = guf(h1.model, h1.inputs, p=0.99)
    r = monte_carlo(h1.model, h1.inputs, trials=5000, seed=7, p=0.99, max_trials=10_000_000)
    expected = result_document(
        g, r, validate_results(g, r, digits=2), model=h1.name, source="h1.yaml"
    )
    assert e.to_dict() == expected
    np.testing.assert_array_equal(e.mcm.estimate, r.estimate)
    assert e.output_names == tuple(h1.output_names)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"method": "gum"}, r"^method must be one of guf, mcm, both, got 'gum'$"),
        ({"p": 1.0}, r"^p \(the coverage probability\) must lie in \(0, 1\), got 1.0$"),
        ({"trials": 100}, r"^trials and adaptive apply to the Monte Carlo method"),
        ({"method": "mcm", "trials": 100, "adaptive": True}, r"^give either a number of trials"),
        ({"method": "mcm", "digits": 4}, r"^digits must be 1 to 3 significant digits, got 4$"),
    ],
)
def test_bad_requests_are_refused_with_the_parameter_named(h1, kwargs, message):
    with pytest.raises(InputError, match=message):
        evaluate_model(h1, **kwargs)


def test_more_trials_than_the_values_kept_is_a_resource_limit(h1):
    with pytest.raises(ResourceLimitError, match=rf"^trials {MAX_VALUES + 1}: give 2 to "):
        evaluate_model(h1, "mcm", trials=MAX_VALUES + 1)


def test_the_notebook_shows_the_report_section(h1):
    """One renderer: the notebook fragment has the validation, GUF and Monte Carlo sections."""
    from mtmetrology.report.results import result_report

    e = evaluate_model(h1, "both", trials=2000, seed=1)
    assert isinstance(e, ModelEvaluation)
    html = e._repr_html_()
    for heading in (
        "Validation of the GUF by Monte Carlo",
        "GUF results, p = 0.95",
        "Monte Carlo results, p = 0.95 (2000 trials)",
    ):
        assert heading in html
    assert "GUF results, p = 0.95" in result_report(e).fragment()
