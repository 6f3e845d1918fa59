"""The one readings reader: customary columns in, internal readings out; refusals name
the file, the line and the axis (used by predict, the SAMBA records and length checks)."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.io.files import InputFileError
from mtmetrology.io.tables import read_csv_table
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.readings_table import readings_from_table, senses_from_table

M = Machine.load("five-axis-wcbxfzyst")


def _table(tmp_path, header: str, rows: list[str]):
    path = tmp_path / "r.csv"
    path.write_text(header + "\n" + "\n".join(rows) + "\n", encoding="utf-8")
    return path, read_csv_table(path)


def test_round_trip_of_customary_readings(tmp_path):
    rng = np.random.default_rng(0)
    q = M.readings_from_customary(
        np.c_[rng.uniform(-100, 100, (7, 3)), rng.uniform(-80, 80, 7), rng.uniform(0, 300, 7),
              rng.uniform(0, 300, 7)]
    )  # fmt: skip
    customary = M.readings_to_customary(q)
    rows = [",".join(f"{v:.12f}" for v in row) for row in customary]
    _, table = _table(tmp_path, ",".join(M.axis_names), rows)
    np.testing.assert_allclose(readings_from_table(M, table), q, rtol=0, atol=1e-12)


def test_a_missing_spindle_column_reads_as_zero(tmp_path):
    _, table = _table(tmp_path, "X,Y,Z,B,C", ["1,2,3,30,45"])
    q = readings_from_table(M, table)
    assert q[0, M.axis_names.index("S")] == 0.0
    np.testing.assert_allclose(q[0, 3:5], np.radians([30.0, 45.0]), rtol=1e-15)


def test_a_reading_outside_the_travel_names_file_line_axis_and_travel(tmp_path):
    path, table = _table(tmp_path, "X,Y,Z,B,C", ["0,0,0,0,0", "0,0,0,120,0"])
    with pytest.raises(InputFileError) as err:
        readings_from_table(M, table)
    assert str(err.value) == (
        f"{path}, line 3: B = 120 deg lies outside the travel of {M.name} [-90, 90] deg; "
        "check the readings or the machine file"
    )


def test_senses_absent_given_and_refused(tmp_path):
    _, table = _table(tmp_path, "X,Y,Z,B,C", ["0,0,0,0,0"])
    assert senses_from_table(M, table) is None
    _, table = _table(tmp_path, "X,Y,Z,B,C,sense_X", ["0,0,0,0,0,-1", "0,0,0,0,0,1"])
    senses = senses_from_table(M, table)
    expected = np.ones((2, M.n_axes))
    expected[0, 0] = -1.0
    np.testing.assert_array_equal(senses, expected)
    path, table = _table(tmp_path, "X,Y,Z,B,C,sense_Y", ["0,0,0,0,0,1", "0,0,0,0,0,0"])
    with pytest.raises(InputFileError) as err:
        senses_from_table(M, table)
    assert str(err.value) == f"{path}, line 3: column 'sense_Y' must be +1 or -1"
