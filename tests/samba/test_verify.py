"""The gauge-block length check (Alami Mchichi (2018) §6.5.3, eq. 6.17)."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.io.files import InputFileError
from mtmetrology.samba import (
    read_length_readings,
    simulate_length_readings,
    verify_length,
)
from mtmetrology.samba.verify import LengthReadings

END_A, END_B = np.array([-100.0, -100.0, 40.0]), np.array([100.0, 100.0, 40.0])  # 45° on the table
LENGTH = float(np.linalg.norm(END_B - END_A))


def _readings(machine, truth, seed, pairs=30):
    rng = np.random.default_rng(seed)
    bc = np.column_stack([rng.uniform(-45, 45, pairs), rng.uniform(0, 360, pairs)])
    _, rows = simulate_length_readings(
        machine, truth, END_A, END_B, bc, tip_radius=machine.tip_radius
    )
    q = machine.readings_from_customary(rows)
    return LengthReadings(tuple(str(i + 1) for i in range(pairs)), q[0::2], q[1::2])


def test_a_perfect_machine_measures_the_length_exactly(machine13):
    check = verify_length(
        machine13, None, _readings(machine13, None, 1), LENGTH, tip_radius=machine13.tip_radius
    )
    assert np.all(np.abs(check.errors_nominal) < 1e-9)


def test_compensation_reduces_the_rms_length_error_below_5_percent(
    machine13, truth13, noisy_calibration
):
    """Gauge lengths at random B/C on the virtual machine: after the calibration (0.5 µm
    noise) the RMS error is below 5 % of the nominal model's."""
    readings = _readings(machine13, truth13, 2)
    check = verify_length(
        machine13,
        noisy_calibration.parameters.values,
        readings,
        LENGTH,
        tip_radius=machine13.tip_radius,
    )
    doc = check.to_dict()
    assert doc["compensated"]["rms"] < 0.05 * doc["nominal"]["rms"]
    assert doc["nominal"]["rms"] > 5.0  # µm: the errors are there to be removed


def test_length_readings_need_both_ends_of_each_pair(tmp_path, machine13):
    path = tmp_path / "g.csv"
    path.write_text("pair,end,X,Y,Z,B,C\n1,a,0,0,0,0,0\n1,c,1,0,0,0,0\n", encoding="utf-8")
    with pytest.raises(InputFileError, match="line 3: end must be 'a' or 'b'"):
        read_length_readings(path, machine13)
    path.write_text("pair,end,X,Y,Z,B,C\n1,a,0,0,0,0,0\n", encoding="utf-8")
    with pytest.raises(InputFileError, match="pair '1' has no end b"):
        read_length_readings(path, machine13)
