"""Machine conditions of a simulated verification: reversal, repeatability, temperatures,
random parts of the geometric errors (Aguado et al. (2019), eqs 3, 7–20)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from mtmetrology.errors import InputError
from mtmetrology.identification import senses_from_sequence
from mtmetrology.tracker import MachineConditions
from mtmetrology.tracker.simulate import effective_readings, geometric_draws


def test_reversal_puts_the_axis_half_the_value_along_its_sense(machine, mesh):
    """B_X = 4 µm: approached in +, X lands 2 µm further; in −, 2 µm short (closed form)."""
    cond = MachineConditions(reversal=np.array([0.004, 0.0, 0.0]), u_sensor=0.0)
    q_eff, _ = effective_readings(np.random.default_rng(0), machine, mesh, cond, 1)
    senses = senses_from_sequence(mesh)
    np.testing.assert_allclose(q_eff[0, :, 0] - mesh[:, 0], 0.002 * senses[:, 0], atol=1e-12)
    assert set(senses[:, 0]) == {-1.0, 1.0}


def test_temperatures_interpolate_between_the_sensors_and_expand_the_scale(machine, mesh):
    """X sensors at 20 and 24 °C over 800–1200 mm: at x = 1000 the axis is at 22 °C and
    lands α·2 K·1000 mm = 23 µm further (α = 11.5 µm/(m·K), u(α) and sensor noise off)."""
    cond = MachineConditions(np.array([[20.0, 24.0], [20, 20], [20, 20]]), u_sensor=0.0,
                             u_cte=np.zeros(3))  # fmt: skip
    q_eff, t_rec = effective_readings(np.random.default_rng(0), machine, mesh, cond, 1)
    i = np.flatnonzero(mesh[:, 0] == 1000.0)[0]
    assert t_rec[0, i, 0] == pytest.approx(22.0)
    assert q_eff[0, i, 0] - 1000.0 == pytest.approx(0.023, rel=1e-12)


def test_repeatability_and_sensor_noise_have_their_standard_deviations(machine, mesh):
    cond = MachineConditions(repeatability=np.array([0.001, 0.002, 0.003]), u_sensor=0.1)
    q_eff, t_rec = effective_readings(np.random.default_rng(1), machine, mesh, cond, 4000)
    d = (q_eff - mesh).reshape(-1, 3)
    np.testing.assert_allclose(d.std(axis=0), [0.001, 0.002, 0.003], rtol=0.01)
    # one error per sensor per test: at a travel end the recorded value scatters by u_sensor
    end = np.flatnonzero(mesh[:, 0] == 800.0)[0]
    assert t_rec[:, end, 0].std() == pytest.approx(0.1, rel=0.05)


@pytest.mark.parametrize("kind", ["normal", "beta"])
def test_random_parts_of_geometric_errors_have_the_stated_u(kind):
    """Eqs 18–20: u_j = 10 % of |θ_j|, normal or Beta(2, 2) on ±√5·u_j (same u): 2·10⁴
    draws, standard deviation within 3 % (sampling error 0.5–0.7 %), support bounded for Beta."""
    theta = np.array([10.0, -4.0, 0.0])
    cond = MachineConditions(geometric_random=0.1, geometric_distribution=kind)
    d = geometric_draws(np.random.default_rng(2), theta, cond, 20_000)
    np.testing.assert_allclose(d[:, :2].std(axis=0), [1.0, 0.4], rtol=0.03)
    assert np.all(d[:, 2] == 0.0)
    if kind == "beta":
        assert np.abs(d[:, 0]).max() <= np.sqrt(5.0)
        assert stats.kurtosis(d[:, 0]) < -0.5  # Beta(2, 2) is platykurtic (−6/7)


def test_bad_conditions_name_the_field():
    with pytest.raises(InputError, match=r"^conditions: cte must be \(3,\) finite numbers"):
        MachineConditions(cte=np.array([1.0, np.nan, 1.0]))
    with pytest.raises(InputError, match=r"^conditions: geometric_distribution must be"):
        MachineConditions(geometric_distribution="uniform")
