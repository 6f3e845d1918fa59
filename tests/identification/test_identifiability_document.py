"""The identifiability report as a JSON document and the null combinations as text."""

import json

import numpy as np
import pytest

from mtmetrology.identification import analyse_identifiability
from mtmetrology.identification.diagnostics import NullDirection


def test_full_rank_report_document():
    """Orthogonal columns of norms 4, 2, 1: scaled singular values 1, raw 4, 2, 1."""
    u, _ = np.linalg.qr(np.random.default_rng(1).standard_normal((12, 3)))
    rep = analyse_identifiability(u * [4.0, 2.0, 1.0], ["a", "b", "c"])
    doc = json.loads(json.dumps(rep.to_dict()))  # plain JSON types only
    assert doc["kind"] == "identifiability-report" and doc["version"] == 1
    assert doc["unknowns"] == ["a", "b", "c"]
    assert doc["rank"] == 3 and doc["n_unknowns"] == 3
    assert doc["condition_raw"] == pytest.approx(4.0)
    assert doc["condition_scaled"] == pytest.approx(1.0)
    np.testing.assert_allclose(doc["singular_values_scaled"], [1.0, 1.0, 1.0])
    np.testing.assert_allclose(doc["singular_values_raw"], [4.0, 2.0, 1.0])
    assert set(doc["observability"]) == {"O1", "O2", "O3", "O4", "O5"}
    assert doc["null_directions"] == [] and doc["message"] == rep.message


def test_rank_deficient_report_document_names_the_combination():
    rng = np.random.default_rng(0)
    j = rng.standard_normal((20, 3))
    j[:, 2] = -3.0 * j[:, 0]
    rep = analyse_identifiability(j, ["a", "b", "c"])
    doc = json.loads(json.dumps(rep.to_dict()))
    assert doc["rank"] == 2 and doc["n_unknowns"] == 3
    assert doc["condition_raw"] is None and doc["condition_scaled"] is None  # not inf
    (null,) = doc["null_directions"]
    assert null["summary"] == "a ~ c"
    terms = {t["name"]: t["coefficient"] for t in null["terms"]}
    assert set(terms) == {"a", "c"}
    # a unit vector with equal shares in column-scaled coordinates
    assert abs(terms["a"]) == pytest.approx(np.sqrt(0.5)) == pytest.approx(abs(terms["c"]))
    assert doc["observability"] == {}


@pytest.mark.parametrize(
    ("terms", "text"),
    [
        ((("E_Y0C", 0.7071), ("E_Y0S", 0.7071)), "0.707·E_Y0C + 0.707·E_Y0S"),
        ((("E_Y0C", 0.7071), ("E_Y0S", -0.7071)), "0.707·E_Y0C − 0.707·E_Y0S"),
        ((("a", -0.8), ("b", 0.6)), "−0.8·a + 0.6·b"),
        ((("a", -0.8), ("b", -0.6)), "−0.8·a − 0.6·b"),
        ((("q", 1.0),), "1·q"),
    ],
)
def test_combination_text(terms, text):
    assert NullDirection(terms).combination() == text


def test_single_term_direction_is_not_observable():
    d = NullDirection((("q", 1.0),))
    assert str(d) == "q (not observable)" and d.names == ("q",)
    assert str(NullDirection((("a", 0.6), ("b", 0.8)))) == "a ~ b"
