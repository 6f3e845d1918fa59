"""R-test files: sensors file, index grid, readings CSV round trip."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.rtest.requests import (
    calibrate_file,
    load_sensors,
    programme_grid,
    simulate_file,
    values_from_pairs,
)

SPHERE = (100.0, 0.0, 50.0)


@pytest.fixture(scope="module")
def machine():
    return Machine.load("five-axis-wcbxfzyst")


def test_grid_includes_the_stop(machine):
    q = programme_grid(machine, ["B=-60:60:30", "C=0:270:90"], SPHERE)
    assert q.shape == (20, 6)
    np.testing.assert_allclose(machine.forward(q), np.tile(SPHERE, (20, 1)), atol=1e-9)


def test_sensors_file(tmp_path):
    (tmp_path / "s.yaml").write_text(
        "kind: rtest-sensors\nversion: 1\ndirections: [[2, 0, 0], [0, 1, 0], [0, 0, 1]]\n"
        "gains: [1.0, 0.99, 1.01]\n"
    )
    sensors = load_sensors(tmp_path / "s.yaml")
    np.testing.assert_allclose(sensors.directions[0], [1.0, 0.0, 0.0])
    (tmp_path / "bad.yaml").write_text("kind: rtest-sensors\nversion: 1\ngains: [1, 1, 1]\n")
    with pytest.raises(InputError, match="missing directions"):
        load_sensors(tmp_path / "bad.yaml")


def test_csv_round_trip_recovers_the_errors(machine, tmp_path):
    truth = values_from_pairs(machine, ["E_X0C=10", "E_B0C=-5"], "--error")
    simulate_file(machine, ["B=-60:60:30", "C=0:315:45"], SPHERE, load_sensors(None), truth,
                  tmp_path / "r.csv")  # fmt: skip
    cal = calibrate_file(machine, tmp_path / "r.csv", load_sensors(None), sphere=SPHERE,
                         sigma=1e-4)  # fmt: skip
    assert cal.value("E_X0C") == pytest.approx(10e-3, abs=1e-7)
    assert cal.value("E_B0C") == pytest.approx(-5e-6, abs=1e-9)


def test_missing_sensor_column_refused(machine, tmp_path):
    (tmp_path / "r.csv").write_text("X,Y,Z,B,C,s1_um,s2_um\n0,0,0,0,0,1,2\n")
    with pytest.raises(InputError, match="s3_um"):
        calibrate_file(machine, tmp_path / "r.csv", load_sensors(None), sphere=SPHERE)
