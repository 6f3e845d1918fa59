"""Air refractive index (updated Edlén, Birch & Downs 1994) against published values, and the
environmental correction: closed-form NDE, exact undo, stated in the result."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.positioning import environment as env
from mtmetrology.positioning.data import Conditions, PositioningTest
from mtmetrology.positioning.workflow import analyse


@pytest.mark.parametrize(
    ("kelvin", "mpa"),
    # IAPWS-IF97 (1997), Table 35: verification values of the saturation-pressure equation
    [(300.0, 0.353658941e-2), (500.0, 0.263889776e1), (600.0, 0.123443146e2)],
)
def test_saturation_pressure_reproduces_iapws_if97(kelvin, mpa):
    assert env.saturation_vapour_pressure(kelvin - 273.15) == pytest.approx(mpa * 1e6, rel=1e-8)


def test_dry_air_at_20_c_and_one_atmosphere_is_birch_and_downs_value():
    # n = 1.00027180 for dry air, 20 °C, 101 325 Pa at 633 nm (Birch & Downs 1994)
    assert env.refractive_index(20.0, 101325.0, 0.0, 633.0) == pytest.approx(1.0002718, abs=1e-8)


def test_standard_air_gives_the_dispersion_formula_itself():
    # the density factor is 1 at the reference of the dispersion formula (15 °C, 101 325
    # Pa, dry): n − 1 = (n_s − 1) within the 1e-8 the equation is stated to
    s2 = (1e3 / 633.0) ** 2
    ns1 = 1e-8 * (8342.54 + 2406147 / (130 - s2) + 15998 / (38.9 - s2))
    assert env.refractive_index(15.0, 101325.0, 0.0, 633.0) - 1 == pytest.approx(ns1, abs=1e-8)


def test_humid_air_is_less_refractive_by_the_water_term():
    dry = env.refractive_index(20.0, 100000.0, 0.0, 633.0)
    wet = env.refractive_index(20.0, 100000.0, 50.0, 633.0)
    pw = 0.5 * env.saturation_vapour_pressure(20.0)
    s2 = (1e3 / 633.0) ** 2
    assert dry - wet == pytest.approx(1e-10 * pw * (3.7345 - 0.0401 * s2), rel=1e-12)


def test_conditions_out_of_range_are_refused():
    with pytest.raises(InputError, match="humidity"):
        env.refractive_index(20.0, 101325.0, 120.0)


def test_nde_closed_form_and_exact_undo():
    # material at 23 °C, α = 11.5e-6: a true 1000 mm reads 1000 (1 + 3 α) mm on the laser
    # (air as compensated); the corrected deviation is the true one
    f = env.correction_factor(1.0, 23.0, 11.5e-6)
    assert f == pytest.approx(1 / (1 + 3 * 11.5e-6), rel=1e-15)
    span = np.array([0.0, 500.0, 1000.0])
    x = np.random.default_rng(1).normal(0, 0.002, (3, 5, 2))
    xc = env.correct(x, span, f)
    np.testing.assert_allclose(env.uncorrect(xc, span, f), x, rtol=0, atol=1e-15)
    read = (span[:, None, None] + x) * (1 + 3 * 11.5e-6) - span[:, None, None]
    np.testing.assert_allclose(env.correct(read, span, f), x, rtol=0, atol=1e-12)


def test_the_result_states_the_correction_and_it_can_be_undone():
    targets = np.array([0.0, 250.0, 500.0, 750.0, 1000.0])
    true = np.random.default_rng(2).normal(0, 0.001, (5, 5, 2))
    f = (1 / env.refractive_index(22.0, 98000.0, 50.0)) / (1 + 2 * 11.5e-6)
    # vacuum-wavelength counts in air of n ≈ 1.00026, on a part 2 K warm
    raw = (targets[:, None, None] + true) / f - targets[:, None, None]
    cond = Conditions(
        air_temperature_C=22.0, air_pressure_Pa=98000.0, material_temperatures_C=[21.0, 23.0]
    )
    res = analyse(PositioningTest(targets, raw, cond))
    e = res.environment
    n = env.refractive_index(22.0, 98000.0, 50.0)
    assert e["n_air"] == n and e["material_C"] == 22.0 and e["air_applied"] and e["nde_applied"]
    assert e["factor"] == pytest.approx((1 / n) / (1 + 2 * 11.5e-6), rel=1e-15)
    np.testing.assert_allclose(
        env.uncorrect(res.deviations, targets - e["datum_mm"], e["factor"]), raw, atol=1e-14
    )
    np.testing.assert_allclose(res.deviations, true, rtol=0, atol=1e-12)


def test_readings_already_compensated_are_left_alone():
    targets = np.array([0.0, 500.0, 1000.0])
    raw = np.random.default_rng(3).normal(0, 0.001, (3, 5, 2))
    cond = Conditions(air_compensated=True, nde_applied=True, air_temperature_C=25.0)
    res = analyse(PositioningTest(targets, raw, cond))
    assert res.environment["factor"] == 1.0
    np.testing.assert_array_equal(res.deviations, raw)
