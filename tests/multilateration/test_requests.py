"""The multilateration requests of the command line (mtmetrology.multilateration.requests)."""

from __future__ import annotations

import pytest

from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.multilateration.requests import calibrate_multilateration_file


@pytest.mark.parametrize("mc", [-1, 1])
def test_a_map_check_of_fewer_than_two_trials_is_refused_before_reading(tmp_path, mc):
    """One Monte Carlo draw has no standard deviation (issue 32: --mc 1 gave a NaN u)."""
    missing = tmp_path / "none.csv"  # refused before the file is looked at
    with pytest.raises(InputError, match=r"^--mc must be 0 \(no check\) or at least 2"):
        calibrate_multilateration_file(missing, Machine.load("three-axis-xfyz"), mc=mc)
