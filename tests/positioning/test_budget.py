"""ISO/TR 230-9 budget: single contributors equal their closed forms, the Monte Carlo check
(JCGM 101) agrees with the GUF within 5 % at every target, bad inputs are refused."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.positioning.budget import DEFAULTS, tr230_9_budget
from mtmetrology.positioning.data import Conditions
from mtmetrology.units import from_internal

TARGETS = np.array([0.0, 180.0, 410.0, 590.0, 820.0, 1000.0])
ZERO = {k: 0.0 for k in DEFAULTS if k != "k"}


def test_material_temperature_and_expansion_alone_give_the_closed_form():
    # u(e) = L sqrt((α u_t)² + ((t − 20) a/√3)²) (JCGM 100, 5.1.2, linear in t and α)
    cond = Conditions(material_temperatures_C=[23.0], expansion_material_per_K=11.5e-6)
    given = ZERO | {"u_material_temperature_K": 0.2, "alpha_half_width_per_K": 2e-6}
    b = tr230_9_budget(TARGETS, cond, **given)
    want = from_internal(TARGETS * math.hypot(11.5e-6 * 0.2, 3.0 * 2e-6 / math.sqrt(3)), "µm")
    np.testing.assert_allclose(b.u_targets_um, want, rtol=1e-6, atol=1e-12)


def test_misalignment_alone_is_the_rectangular_cosine_error():
    # e ∈ [−L θ²/2, 0] rectangular: u = L θ² / (2 √12), scaled with L
    b = tr230_9_budget(TARGETS, Conditions(), **(ZERO | {"misalignment_rad": 1e-3}))
    want = from_internal(TARGETS * 1e-6 / (2 * math.sqrt(12)), "µm")
    np.testing.assert_allclose(b.u_targets_um, want, rtol=1e-9, atol=1e-12)


def test_local_terms_give_u_of_b_and_r():
    b = tr230_9_budget(
        TARGETS, Conditions(), **(ZERO | {"abbe_offset_mm": 80, "angular_change_rad": 1e-5})
    )
    assert b.parameter_u()["R"] == pytest.approx(0.8 / math.sqrt(3), rel=1e-12)
    assert b.parameter_u()["E"] == pytest.approx(0.8 / math.sqrt(3), rel=1e-9)


def test_environmental_variation_error_adds_to_every_target_and_to_b_and_r():
    b = tr230_9_budget(TARGETS, Conditions(), **(ZERO | {"eve_um": 1.2}))
    np.testing.assert_allclose(b.u_targets_um, 0.6 / math.sqrt(3), rtol=1e-9)
    assert b.parameter_u()["B"] == pytest.approx(0.6 / math.sqrt(3), rel=1e-12)


def test_monte_carlo_agrees_with_the_guf_within_5_percent():
    cond = Conditions(air_temperature_C=24.0, humidity_percent=70.0, material_temperatures_C=[24.5])
    b = tr230_9_budget(TARGETS, cond, misalignment_rad=5e-4, eve_um=0.4)
    mc = b.monte_carlo(trials=100_000, seed=230)
    np.testing.assert_allclose(mc, b.u_targets_um, rtol=0.05)
    assert b.to_dict()["k"] == 2.0 and b.rows[0]["input"] == "delta_laser"


@pytest.mark.parametrize(("key", "value"), [("dead_path_m", 1.0), ("dead_path_mm", -1.0)])
def test_bad_budget_inputs_are_refused(key, value):
    with pytest.raises(InputError, match=key):
        tr230_9_budget(TARGETS, Conditions(), **{key: value})
