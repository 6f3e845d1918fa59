"""The virtual five-axis machine shared by the SAMBA examples: preset, artefact, truth.

The simulated machine is the five-axis preset with errors of the size identified by
Sepahi Boroujeni (2021), Table 5-2, probed on a SAMBA artefact of four master balls and a
305 mm scale bar with 1 µm probing noise. A helper of ``examples/`` (imported by the
scripts beside it), not a script.

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine Tool
Metrology*. PhD thesis, Polytechnique Montréal. Alami Mchichi, N. (2018). *Étalonnage des
machines-outils à cinq axes : configuration optimisée des artefacts et de la séquence de
mesure de la méthode SAMBA en vue d'une estimation efficace des erreurs géométriques*. PhD
thesis, École Polytechnique de Montréal.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.kinematics.machine import Machine
from mtmetrology.samba import SambaSetup
from mtmetrology.units import to_internal

PRESET = "five-axis-wcbxfzyst"
SETUP = SambaSetup(
    balls={
        "1": (-80.0, -40.0, 100.0),
        "2": (80.0, -40.0, 150.0),
        "3": (80.0, 120.0, 75.0),
        "4": (-80.0, 120.0, 125.0),
    },
    scale_bar={"SB1": (-152.60525, 0.0, 30.0), "SB2": (152.60525, 0.0, 30.0)},
)
ARTEFACT_YAML = """kind: samba-artefact
balls:
  - {id: "1", diameter_mm: 12.7}
  - {id: "2", diameter_mm: 12.7}
  - {id: "3", diameter_mm: 12.7}
  - {id: "4", diameter_mm: 12.7}
  - {id: SB1, diameter_mm: 12.7}
  - {id: SB2, diameter_mm: 12.7}
scale_bar: {ends: [SB1, SB2], length_mm: 305.2105, u_mm: 0.0012}
stylus_tip_diameter_mm: 5.925
"""
# B within ±45°: beyond it the scale-bar and corner balls leave the X and Z travel.
GRID = [(b, c) for b in (-45, -20, 0, 20, 45) for c in range(0, 360, 60)]
PROBING_SIGMA_UM = 1.0
BAR_U_MM = 0.0012

# The "true" machine of the simulation: errors of the size of Sepahi Boroujeni (2021),
# Table 5-2 (µm, µrad, µm/m).
TRUE_ERRORS = {
    "E_A0B": -8.73,
    "E_C0B": -2.80,
    "E_X0C": -104.59,
    "E_A0C": -18.75,
    "E_B0C": -4.40,
    "E_B0Z": -12.23,
    "E_A0Y": -13.87,
    "E_C0Y": 25.81,
    "E_XX1": 75.6,
    "E_YY1": 102.0,
    "E_ZZ1": 113.4,
    "E_Y0S": 18.72,
    "E_X0S": -107.15,
}

# The gauge-block bipoint of Sepahi Boroujeni (2021), Table 7-1 (mm and degrees).
GAUGE_READINGS = {
    "X": [-138.5650, -61.2880],
    "Y": [94.6560, 48.3440],
    "Z": [196.2320, 246.8170],
    "B": [-42.0, -64.0],
    "C": [-293.0, -124.0],
}

NOISE_UM = 1.0
# A gauge block lying diagonally on the table, probed at 30 random (B, C) indexations.
GAUGE_END_A, GAUGE_END_B = "-100,-100,40", "100,100,40"
GAUGE_LENGTH_MM = 282.842712
GAUGE_U_MM = 0.0005
GAUGE_PAIRS = 30
# The drawing's tolerance on the gauge length: nominal, lower and upper deviation (mm).
GAUGE_TOLERANCE = f"{GAUGE_LENGTH_MM},-0.010,0.010"


def true_errors(m: Machine) -> np.ndarray:
    """The error vector of the simulated truth (internal units), in ``m``'s order."""
    units = m.parameter_units
    return np.array(
        [to_internal(TRUE_ERRORS[n], u) for n, u in zip(m.parameter_names, units, strict=True)]
    )
