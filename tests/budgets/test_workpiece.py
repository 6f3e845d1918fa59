"""u_w of an ISO 15530-3 budget from its inputs (mtmetrology.budgets.workpiece)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from mtmetrology.budgets.workpiece import WorkpieceVariation
from mtmetrology.errors import InputError

# L = 200 mm, α = 11.5 µm/(m·K), a_α = √3 µm/(m·K) (u_α = 1 µm/(m·K)), T = 25 °C,
# u_T = 0.4 K, F = √12 µm (u_F = 1 µm): the four terms by hand, in mm.
INPUTS = dict(
    length=200.0,
    alpha=11.5e-6,
    alpha_half_width=math.sqrt(3.0) * 1e-6,
    temperature=25.0,
    u_temperature=0.4,
    form=math.sqrt(12.0) * 1e-3,
)
TERMS = {
    "alpha": 200.0 * 5.0 * 1e-6,  # L·(T − 20)·u_α = 1.0 µm
    "temperature": 200.0 * 11.5e-6 * 0.4,  # L·α·u_T = 0.92 µm
    "product": 200.0 * 1e-6 * 0.4,  # L·u_α·u_T = 0.08 µm
    "form": 1e-3,  # F/(2√3) = 1.0 µm
}


def test_u_w_is_the_closed_form():
    w = WorkpieceVariation(**INPUTS)
    got = w.components()
    assert got.keys() == TERMS.keys()
    for name, value in TERMS.items():
        assert got[name] == pytest.approx(value, rel=1e-12), name
    assert w.u() == pytest.approx(math.sqrt(1e-6 + 0.92e-3**2 + 0.08e-3**2 + 1e-6), rel=1e-12)


def test_alone_the_expansion_term_is_the_standards_u_w():
    """ISO 15530-3, clause 7: u_w = (t − 20 °C)·u_α·l."""
    w = WorkpieceVariation(length=80.0, alpha_half_width=2e-6, temperature=18.5)
    assert w.u() == pytest.approx(1.5 * (2e-6 / math.sqrt(3.0)) * 80.0, rel=1e-12)
    assert WorkpieceVariation(length=80.0, alpha_half_width=2e-6, temperature=20.0).u() == 0.0


def test_u_w_is_the_standard_deviation_of_its_measurement_model():
    """Monte Carlo of δ = L·[(α + δα)(T − 20 + δT) − α(T − 20)] + δ_F with δα rectangular
    ±a_α, δT normal u_T, δ_F rectangular ±F/2 (u_w² is its exact variance)."""
    w = WorkpieceVariation(**INPUTS)
    rng = np.random.default_rng(30)
    n = 400_000
    d_alpha = rng.uniform(-1.0, 1.0, n) * w.alpha_half_width
    d_t = rng.normal(0.0, w.u_temperature, n)
    d_f = rng.uniform(-0.5, 0.5, n) * w.form
    dt = w.temperature - 20.0
    delta = w.length * ((w.alpha + d_alpha) * (dt + d_t) - w.alpha * dt) + d_f
    # the sample standard deviation of 4e5 draws is within 0.5 % of σ (3.5 standard errors)
    assert np.std(delta, ddof=1) == pytest.approx(w.u(), rel=5e-3)


@pytest.mark.parametrize(
    ("kwargs", "option"),
    [
        ({"temperature": 300.0}, "--temperature"),
        ({"temperature": math.nan}, "--temperature"),
        ({"alpha_half_width": -1e-6}, "--alpha-half-width"),
        ({"u_temperature": -0.1}, "--u-temperature"),
        ({"form": -1e-3}, "--form"),
        ({"length": 0.0}, "--length"),
        ({"temperature": None}, "--temperature"),  # needed with the half-width
        ({"alpha": 0.0}, "--alpha"),  # needed with u_T
    ],
)
def test_bad_inputs_name_their_option(kwargs, option):
    with pytest.raises(InputError, match=f"^{option}:"):
        WorkpieceVariation(**(INPUTS | kwargs))


def test_round_trip_and_formula_stated():
    w = WorkpieceVariation(**INPUTS)
    doc = json.loads(json.dumps(w.to_dict()))
    assert WorkpieceVariation.from_dict(doc) == w
    assert doc["u_w"] == pytest.approx(w.u())
    assert doc["um"]["u_w"] == pytest.approx(w.u() * 1e3)
    assert doc["formula"].startswith("u_w = √(L²·[(T − 20 °C)²·u_α² + α²·u_T² + u_α²·u_T²]")
