"""The neutral ballbar CSV: round trip and refusals at the door, one line naming what is missing."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.ballbar.records import (
    BallbarConditions,
    nominal_test,
    read_ballbar,
    write_ballbar,
)
from mtmetrology.errors import InputError

CONDITIONS = BallbarConditions("XY", 100.0, 1000.0, np.array([10.0, 20.0, 0.0]), name="xy")
HEADER = "angle_deg,direction,reading_um,X,Y,Z"


def _rows(n=36, directions=("ccw", "cw"), skip=(), reading=0.0):
    rows = []
    for d in directions:
        angles = np.arange(n) * 360.0 / n
        for a in angles if d == "ccw" else angles[::-1]:
            if a in skip:
                continue
            t = np.radians(a)
            rows.append(f"{a},{d},{reading},{10 + 100 * np.cos(t)},{20 + 100 * np.sin(t)},0")
    return rows


def _write(tmp_path, rows, header=HEADER):
    p = tmp_path / "bb.csv"
    p.write_text("\n".join([header, *rows]) + "\n")
    return p


def test_round_trip(tmp_path):
    test = nominal_test(CONDITIONS, 72)
    test = test.with_reading(1e-3 * np.sin(3 * test.angle))
    write_ballbar(test, tmp_path / "t.csv")
    back = read_ballbar(tmp_path / "t.csv", CONDITIONS)
    assert len(back) == 144
    np.testing.assert_allclose(back.reading, test.reading, atol=1e-9)
    np.testing.assert_allclose(back.angle, test.angle, atol=1e-9)
    np.testing.assert_array_equal(back.direction, test.direction)


def test_reads_a_file(tmp_path):
    test = read_ballbar(_write(tmp_path, _rows(reading=1.5)), CONDITIONS)
    assert test.direction.tolist().count(1) == 36
    np.testing.assert_allclose(test.reading, 1.5e-3)


def test_gap_in_angle_refused_naming_the_arc(tmp_path):
    with pytest.raises(InputError) as err:
        read_ballbar(_write(tmp_path, _rows(skip=(90.0,))), CONDITIONS)
    msg = str(err.value)
    assert "gap in angle" in msg and "80° and 100°" in msg and "\n" not in msg


def test_missing_direction_refused(tmp_path):
    with pytest.raises(InputError, match="no cw run"):
        read_ballbar(_write(tmp_path, _rows(directions=("ccw",))), CONDITIONS)


def test_unknown_direction_refused_by_line(tmp_path):
    rows = _rows()
    rows[3] = rows[3].replace("ccw", "up")
    with pytest.raises(InputError, match=r"line 5: direction 'up'"):
        read_ballbar(_write(tmp_path, rows), CONDITIONS)


def test_angles_not_advancing_refused(tmp_path):
    rows = _rows()
    rows[2], rows[3] = rows[3], rows[2]
    with pytest.raises(InputError, match="does not advance in the ccw run"):
        read_ballbar(_write(tmp_path, rows), CONDITIONS)


def test_commanded_point_off_the_circle_refused(tmp_path):
    other = BallbarConditions("XY", 150.0, 1000.0, np.array([10.0, 20.0, 0.0]))
    with pytest.raises(InputError, match="off the stated circle"):
        read_ballbar(_write(tmp_path, _rows()), other)


def test_missing_column_refused(tmp_path):
    rows = [",".join(r.split(",")[:3]) for r in _rows()]
    with pytest.raises(InputError, match="X"):
        read_ballbar(_write(tmp_path, rows, "angle_deg,direction,reading_um"), CONDITIONS)


@pytest.mark.parametrize(
    "kwargs, word",
    [({"plane": "XZ"}, "plane"), ({"radius": -1.0}, "radius"), ({"feed": 0.0}, "feed")],
)
def test_bad_conditions_refused(kwargs, word):
    base = {"plane": "XY", "radius": 100.0, "feed": 1000.0, "centre": np.zeros(3)}
    with pytest.raises(InputError, match=word):
        BallbarConditions(**{**base, **kwargs})
