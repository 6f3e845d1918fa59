"""The four master balls of the identifiability check, shared by the design tests."""

import numpy as np

#: The identifiability check's four balls (digest identifiability-check.md, Q1/Q2).
LAB_IDS = ["1", "2", "3", "4"]
LAB_CENTRES = np.array(
    [(-80.0, -40.0, 100.0), (80.0, -40.0, 150.0), (80.0, 120.0, 75.0), (-80.0, 120.0, 175.0)]
)
