"""Helpers of the CMM tests: a ball plate, styli, plate positions (virtual bridge CMM)."""

from __future__ import annotations

from mtmetrology.cmm.files import BallPlate, PositionSet
from mtmetrology.units import to_internal

SIGMA = to_internal(0.5, "µm")  # the source's repeatability (Salacheep 2016, §4.4)
ALL = ["P0", "PX1", "PX2", "PY1", "PY2"]


def make_plate(n: int, pitch: float, u_mm: float = 0.0005) -> BallPlate:
    balls = [
        {"id": f"{n * j + i:02d}", "x_mm": i * pitch, "y_mm": j * pitch, "z_mm": 0.0}
        for j in range(n)
        for i in range(n)
    ]
    return BallPlate(kind="ball-plate", balls=balls, u_mm=u_mm)


def make_positions(*specs) -> PositionSet:
    return PositionSet(
        kind="ballplate-positions",
        positions=[
            {"id": i, "origin_mm": o, "rotation_deg": r, "probes": p} for i, o, r, p in specs
        ],
    )


#: horizontal, two vertical (XZ and YZ planes), tilted; D is the held-out diagonal
TRAIN = [
    ("H", [330, 230, 150], [0, 0, 0], ALL),
    ("VX", [330, 500, 10], [90, 0, 0], ALL),
    ("VY", [600, 230, 10], [90, 0, 90], ALL),
    ("T", [330, 230, 120], [30, 0, 0], ALL),
]
DIAGONAL = ("D", [300, 300, 10], [90, 0, 45], ALL)
