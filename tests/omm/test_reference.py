"""Tests for mtmetrology.omm.reference (Sepahi Boroujeni (2021), §6.4, eqs. 6-16 to 6-19)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.stats import norm

from mtmetrology.errors import InputError
from mtmetrology.omm.reference import coverage_probability, thermal_reference_value
from mtmetrology.units import to_internal

UM = to_internal(1.0, "µm")
THESIS = dict(
    expansion_coefficient=10.8e-6,
    expansion_coefficient_uncertainty=0.15e-6,
    temperature_difference=1.75,
    temperature_difference_uncertainty=0.005 / math.sqrt(3),
)


def test_gauge_reference_value_is_500_00945_mm_with_u_0_20_um():
    """§6.4: 500.0000 mm, U = 0.3 µm (k = 2) → y_cal = 500.00945 mm, u_cal = 0.20 µm."""
    r = thermal_reference_value(500.0, 0.15 * UM, name="gauge_length", **THESIS)
    assert r.value == pytest.approx(500.00945, abs=1e-9)
    assert round(r.standard_uncertainty / UM, 2) == 0.20
    # eq. 6-19 written out independently of the GUF engine.
    y, a, dt = 500.0, 10.8e-6, 1.75
    u = math.sqrt(
        (1 + a * dt) ** 2 * (0.15 * UM) ** 2
        + (y * dt * 0.15e-6) ** 2
        + (y * a * THESIS["temperature_difference_uncertainty"]) ** 2
    )
    assert r.standard_uncertainty == pytest.approx(u, rel=1e-12)


def test_sphere_reference_value_is_19_05036_mm_with_u_0_25_um():
    """§6.4: 19.0500 mm, U = 0.5 µm → 19.05036 mm (text rounds to 19.0504) and 0.25 µm."""
    r = thermal_reference_value(19.05, 0.25 * UM, **THESIS)
    assert round(r.value, 5) == 19.05036
    assert round(r.standard_uncertainty / UM, 2) == 0.25


def test_reference_document_is_an_uncertainty_result():
    doc = json.loads(json.dumps(thermal_reference_value(500.0, 0.15 * UM, **THESIS).to_dict()))
    assert doc["kind"] == "uncertainty-result" and doc["version"] == 1
    assert doc["method"] == "guf"
    (out,) = doc["outputs"]
    assert out["unit"] == "mm" and out["k"] == pytest.approx(1.959964, abs=1e-6)
    assert out["interval"] == pytest.approx([out["value"] - out["U"], out["value"] + out["U"]])
    assert [row["input"] for row in doc["budget"]["reference_value"]] == [
        "y_cal_20",
        "alpha",
        "delta_T",
    ]


def test_eq_6_16_example_gives_p_1():
    """Table 7-1 gauge length 499.9966 mm, U = 18 µm, y_cal = 500.0095 mm → p = 1.0."""
    assert coverage_probability(499.9966, 18 * UM, 500.0095, 0.2 * UM) == 1.0


def test_coverage_probability_limits():
    # Reference exactly at the interval end: half its mass is inside.
    assert coverage_probability(10.0, 0.01, 10.01, 0.0002) == pytest.approx(0.5, abs=1e-12)
    # Far outside: 0; zero reference uncertainty: an indicator (closed interval).
    assert coverage_probability(10.0, 0.001, 10.01, 0.0002) == pytest.approx(0.0, abs=1e-15)
    assert coverage_probability(np.array([10.0, 10.0]), [0.01, 0.009], 10.01, 0.0).tolist() == [
        1.0,
        0.0,
    ]


def test_mean_coverage_of_honest_k2_intervals_is_95_4_percent():
    """y ~ N(y_cal, σ²) with U = 2σ: mean p estimates 2Φ(2) − 1 = 0.9545.

    20 000 draws: standard error 0.0015; the test allows 4 standard errors.
    """
    rng = np.random.default_rng(2021)
    sigma = 5 * UM
    y = 500.0 + rng.normal(0.0, sigma, 20_000)
    p = coverage_probability(y, 2 * sigma, 500.0, 0.2 * UM)
    assert abs(p.mean() - (2 * norm.cdf(2) - 1)) < 4 * 0.0015


@pytest.mark.parametrize(
    "kwargs",
    [
        {"expansion_coefficient_uncertainty": -1e-6},
        {"temperature_difference": math.nan},
    ],
)
def test_bad_reference_inputs_are_refused(kwargs):
    (name,) = kwargs
    with pytest.raises(InputError, match=f"^{name}: "):
        thermal_reference_value(500.0, 0.15 * UM, **{**THESIS, **kwargs})
    with pytest.raises(InputError, match=r"^expanded_uncertainty must be >= 0"):
        coverage_probability(1.0, -0.1, 1.0, 0.1)
