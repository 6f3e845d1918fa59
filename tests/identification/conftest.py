"""A SAMBA set-up like the identifiability check's (digest identifiability-check.md)."""

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.samba import (
    SambaSetup,
    load_artefact,
    load_balls,
    read_poses,
    read_records,
    simulate_records,
)
from mtmetrology.samba import calibrate as samba_calibrate
from mtmetrology.units import to_internal


@pytest.fixture(scope="session")
def samba_setup() -> SambaSetup:
    """4 master balls on stems of different lengths and a 305.21 mm bar along X."""
    return SambaSetup(
        balls={
            "1": (-80.0, -40.0, 100.0),
            "2": (80.0, -40.0, 150.0),
            "3": (80.0, 120.0, 75.0),
            "4": (-80.0, 120.0, 175.0),
        },
        scale_bar={"SB1": (-152.60525, 0.0, 30.0), "SB2": (152.60525, 0.0, 30.0)},
    )


# -- the virtual 13-parameter SAMBA test of Sepahi Boroujeni (2021) Table 5-2 size, for the
#    uncertainty of an identification (tests/identification/test_identification_uncertainty.py)
EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "samba"
NOISE = float(to_internal(0.5, "µm"))  # probing noise of one reading, mm


@dataclass(frozen=True)
class VirtualSamba:
    machine: Machine
    truth: np.ndarray
    balls: np.ndarray
    programme: object
    artefact: object
    folder: Path

    def calibration(self, noise: float = 0.0, seed: int | None = None):
        """Records of the virtual test (noise in mm), written to CSV and read back as a user's
        file would be, calibrated with the tool estimated."""
        path = self.folder / f"records-{noise}-{seed}.csv"
        simulate_records(
            self.machine,
            self.truth,
            self.balls,
            self.programme,
            self.artefact,
            noise=noise,
            seed=seed,
        ).write(path)
        rec = read_records(path, self.machine, self.artefact)
        return samba_calibrate(self.machine, rec, self.artefact, sigma=NOISE, estimate_tool=True)


@pytest.fixture(scope="session")
def virtual_samba(tmp_path_factory) -> VirtualSamba:
    machine = Machine.load("five-axis-wcbxfzyst", "13")
    return VirtualSamba(
        machine,
        ParameterSet.load(EXAMPLES / "truth.json", machine).vector_for(machine),
        load_balls(EXAMPLES / "balls.yaml").centres(),
        read_poses(EXAMPLES / "poses.csv"),
        load_artefact(EXAMPLES / "artefact.yaml"),
        tmp_path_factory.mktemp("virtual-samba"),
    )
