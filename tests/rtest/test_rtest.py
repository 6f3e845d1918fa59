"""Static R-test on the five-axis preset: sign pins, exact recovery, rank, coverage."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.rtest.calibrate import calibrate, simulate
from mtmetrology.rtest.model import Sensors, indexations, rotary_location_candidates

SPHERE = np.array([100.0, 0.0, 50.0])
TRUTH = {
    "E_A0B": 15e-6,
    "E_C0B": 8e-6,
    "E_X0C": 10e-3,
    "E_A0C": 20e-6,
    "E_B0C": -10e-6,
}


@pytest.fixture(scope="module")
def machine():
    return Machine.load("five-axis-wcbxfzyst")


def _programme(machine, b_deg=(-60, -30, 0, 30, 60), c_deg=range(0, 360, 45)):
    b, c = np.meshgrid(np.radians(b_deg), np.radians(list(c_deg)), indexing="ij")
    rotary = np.column_stack([b.ravel(), c.ravel(), np.zeros(b.size)])
    return indexations(machine, SPHERE, rotary)


def test_candidates_are_the_rotary_location_errors(machine):
    assert rotary_location_candidates(machine) == [
        "E_X0B",
        "E_Z0B",
        "E_A0B",
        "E_C0B",
        "E_X0C",
        "E_Y0C",
        "E_A0C",
        "E_B0C",
    ]


def test_sign_of_a_c_axis_shift(machine):
    # E_X0C > 0 displaces the C axis and the table by +X: at B = 0 the sphere sits +X of
    # the nest at every C, and the +X sensor reads +E_X0C
    q = _programme(machine, b_deg=(0,), c_deg=(0, 90, 180, 270))
    s = simulate(machine, q, Sensors(), {"E_X0C": 5e-3}, sphere=SPHERE)
    np.testing.assert_allclose(s, np.tile([5e-3, 0.0, 0.0], (4, 1)), atol=1e-9)


def test_location_errors_recovered_exactly(machine):
    q = _programme(machine)
    sensors = Sensors()
    s = simulate(
        machine,
        q,
        sensors,
        {**TRUTH, "E_Y0C": -5e-3},
        sphere=SPHERE + np.array([0.01, -0.02, 0.005]),
        zeros=[3e-3, -1e-3, 2e-3],
    )
    cal = calibrate(machine, q, s, sensors, sphere=SPHERE, sigma=1e-3)
    # shifts of the B line and the C line along Y move the sphere by one vector in the
    # tool frame at every indexation: the sensor zeros absorb them
    dropped = dict(cal.datum.dropped)
    assert dropped == {
        "E_X0B": ("sensor 1 zero",),
        "E_Y0C": ("sensor 2 zero",),
        "E_Z0B": ("sensor 3 zero",),
    }
    for name, value in TRUTH.items():
        assert cal.value(name) == pytest.approx(value, abs=1e-12), name
    doc = cal.to_dict()
    assert (doc["kind"], doc["category"]) == ("r-test", "calibration")
    assert doc["identifiability"]["rank"] == len(cal.names)


def test_four_tilted_sensors_with_gains(machine):
    q = _programme(machine)
    tilt = np.array([[1, 0, -1], [0, 1, -1], [-1, 0, -1], [0, -1, -1]], dtype=float)
    sensors = Sensors(tilt, np.array([1.02, 0.98, 1.0, 1.01]))
    s = simulate(machine, q, sensors, TRUTH, sphere=SPHERE, zeros=[1e-3, 0.0, -2e-3, 0.5e-3])
    cal = calibrate(machine, q, s, sensors, sphere=SPHERE, sigma=1e-3)
    for name, value in TRUTH.items():
        assert cal.value(name) == pytest.approx(value, abs=1e-12), name


def test_error_motions_with_more_indexations(machine):
    q = _programme(machine, b_deg=range(-90, 91, 15), c_deg=range(0, 360, 15))
    truth = {**TRUTH, "E_XC2": 3e-3, "E_ZB1": 2e-3}
    s = simulate(machine, q, Sensors(), truth, sphere=SPHERE)
    cand = [*rotary_location_candidates(machine), "E_XC2", "E_ZB1", "E_AC1", "E_XB2"]
    cal = calibrate(machine, q, s, Sensors(), sphere=SPHERE, parameters=cand, sigma=1e-3)
    for name in ("E_XC2", "E_ZB1", "E_AC1", "E_XB2"):
        assert cal.value(name) == pytest.approx(truth.get(name, 0.0), abs=1e-12), name


@pytest.mark.parametrize(
    "directions, gains, word",
    [
        (np.eye(3)[:2], np.ones(2), "3 or 4"),
        (np.array([[1, 0, 0], [0, 1, 0], [1, 1, 0]]), np.ones(3), "span"),
        (np.eye(3), np.array([1.0, -1.0, 1.0]), "gains"),
    ],
)
def test_bad_sensors_refused(directions, gains, word):
    with pytest.raises(InputError, match=word):
        Sensors(np.asarray(directions, dtype=float), gains)


@pytest.mark.slow
def test_coverage_of_2u_over_repeated_virtual_tests(machine):
    """200 virtual R-tests, sensor noise 0.5 µm, σ from the residuals: each location error
    within 2u of the truth at the Student rate for ν = 109, inside the binomial 0.1 %
    acceptance interval, and the mean of ((x̂ − x)/u)² within 3 standard errors of
    ν/(ν − 2)."""
    q = _programme(machine)
    sensors = Sensors()
    clean = simulate(machine, q, sensors, TRUTH, sphere=SPHERE)
    rng = np.random.default_rng(20261128)
    n_tests = 200
    z = {name: [] for name in TRUTH}
    for _ in range(n_tests):
        noisy = clean + rng.normal(0.0, 0.5e-3, clean.shape)
        cal = calibrate(machine, q, noisy, sensors, sphere=SPHERE)
        for name, value in TRUTH.items():
            z[name].append((cal.value(name) - value) / cal.u(name))
    nu = clean.size - (len(TRUTH) + 6)
    p = stats.t.cdf(2.0, nu) - stats.t.cdf(-2.0, nu)
    low, high = stats.binom.interval(0.999, n_tests, p)
    for name, values in z.items():
        values = np.asarray(values)
        assert low <= np.sum(np.abs(values) <= 2.0) <= high, name
        assert abs(np.mean(values**2) - nu / (nu - 2)) < 3 * np.sqrt(2.0 / n_tests), name
