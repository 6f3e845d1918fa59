"""Simulated records: drift, raw-point layout and reversal senses."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.io.files import InputFileError
from mtmetrology.samba import ProbingProgramme, simulate_records
from mtmetrology.units import to_internal


def _linear(records, campaign_column=False):
    start = 2 if campaign_column else 1
    return np.array([[float(v) for v in row[start : start + 3]] for row in records.rows])


def test_drift_is_a_ramp_of_the_stated_amplitude(machine13, truth13, balls, programme, artefact):
    drift = float(to_internal(2.0, "µm"))
    still = simulate_records(machine13, truth13, balls, programme, artefact)
    moved = simulate_records(machine13, truth13, balls, programme, artefact, drift=drift, seed=1)
    shift = _linear(moved) - _linear(still)
    assert np.allclose(shift[0], 0.0, atol=1e-6)
    assert abs(np.linalg.norm(shift[-1]) - drift) < 2e-6
    ramp = np.linspace(0.0, 1.0, len(programme))
    np.testing.assert_allclose(shift, np.outer(ramp, shift[-1]), atol=2e-6)


def test_raw_points_carry_unit_approach_directions(machine13, truth13, balls, programme, artefact):
    raw = simulate_records(
        machine13, truth13, balls, programme, artefact, raw_points=True, points_per_ball=6
    )
    assert raw.header[:2] == ("measurement", "ball") and len(raw) == 6 * len(programme)
    ijk = np.array([[float(v) for v in row[-3:]] for row in raw.rows])
    np.testing.assert_allclose(np.linalg.norm(ijk, axis=1), 1.0, atol=2e-6)  # 6 decimals
    assert np.allclose(ijk[5], [0.0, 0.0, -1.0])  # the pole is approached downwards
    with pytest.raises(InputFileError, match="at least 5"):
        simulate_records(
            machine13, truth13, balls, programme, artefact, raw_points=True, points_per_ball=4
        )


def test_a_ball_without_a_centre_is_refused(machine13, balls, artefact):
    prog = ProbingProgramme(("7",), np.zeros(1), np.zeros(1), np.zeros(1))
    with pytest.raises(InputFileError, match="ball '7' has no centre"):
        simulate_records(machine13, None, balls, prog, artefact)
