"""A SAMBA set-up like the identifiability check's (digest identifiability-check.md)."""

import pytest

from mtmetrology.samba import SambaSetup


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
