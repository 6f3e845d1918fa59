"""Files of a SAMBA design: candidate ball grid, fixed balls, candidate indexations.

Ball grid (``--balls-from``)::

    kind: samba-ball-grid
    x_mm: [-160, -80, 0, 80, 160]        # pallet positions (5 x 4 at 80 mm pitch,
    y_mm: [-120, -40, 40, 120]           #  seed 004 §5.5)
    stems_mm: [75, 100, 125, 150, 175]   # ball centre height above the pallet
    scale_bar: {centres_mm: [[-152.78, 0, 30], [152.78, 0, 30]], u_mm: 0.001}

Fixed balls (``--balls``)::

    kind: samba-balls
    balls:
      - {id: "1", centre_mm: [-80, -40, 100]}
    scale_bar: {centres_mm: [[-152.78, 0, 30], [152.78, 0, 30]], u_mm: 0.001}

Candidate indexations (``--indexations``): a CSV with columns ``B,C`` in degrees.
Without a scale bar section the bar of seed 004 is used: 305.5690 mm along X at y = 0,
30 mm above the pallet, u = 0.001 mm (Alami Mchichi 2018, §5.6: u_scale_bar).
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from mtmetrology.errors import InputError
from mtmetrology.io.documents import load_document
from mtmetrology.io.files import InputFileError
from mtmetrology.io.schema import describe_validation_error
from mtmetrology.io.tables import read_csv_table

__all__ = [
    "SEED004_GRID",
    "BallGridFile",
    "BallsFile",
    "ScaleBarPlacement",
    "axis_grid",
    "default_indexations",
    "load_ball_grid",
    "load_balls",
    "load_validated",
    "read_indexations",
]

#: Seed 004 scale bar: 305.5690 mm centre to centre (Alami Mchichi 2018, §5.3).
SEED004_BAR_LENGTH_MM = 305.5690


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class ScaleBarPlacement(_Strict):
    """Scale-bar ball centres (workpiece frame, mm) and the standard uncertainty of its
    calibrated length (mm)."""

    ends: tuple[str, str] = ("SB1", "SB2")
    centres_mm: tuple[tuple[float, float, float], tuple[float, float, float]] = (
        (-0.5 * SEED004_BAR_LENGTH_MM, 0.0, 30.0),
        (0.5 * SEED004_BAR_LENGTH_MM, 0.0, 30.0),
    )
    u_mm: float = Field(default=0.001, gt=0)

    @model_validator(mode="after")
    def _distinct(self):
        if self.ends[0] == self.ends[1]:
            raise ValueError("scale_bar ends must be two different ids")
        if np.linalg.norm(np.subtract(*self.centres_mm)) <= 0:
            raise ValueError("scale_bar centres_mm must be two different points")
        return self

    @property
    def length(self) -> float:
        return float(np.linalg.norm(np.subtract(*self.centres_mm)))


class BallGridFile(_Strict):
    """Candidate balls: every pallet position (x, y) with every stem length."""

    kind: Literal["samba-ball-grid"]
    x_mm: list[float] = Field(min_length=1)
    y_mm: list[float] = Field(min_length=1)
    stems_mm: list[float] = Field(min_length=1)
    scale_bar: ScaleBarPlacement = ScaleBarPlacement()

    @model_validator(mode="after")
    def _positive_stems(self):
        if min(self.stems_mm) <= 0:
            raise ValueError("stems_mm must be positive heights above the pallet")
        return self

    def candidates(self, table_z_mm: float = 0.0) -> tuple[list[str], np.ndarray]:
        """Ids ``x<x>y<y>h<stem>`` and centres (n, 3), x fastest, then y, then stem."""
        ids, centres = [], []
        for h in self.stems_mm:
            for y in self.y_mm:
                for x in self.x_mm:
                    ids.append(f"x{x:g}y{y:g}h{h:g}")
                    centres.append((x, y, table_z_mm + h))
        return ids, np.array(centres, dtype=float)


#: Seed 004 candidate grid, the default of ``mtm samba plan`` without ``--balls-from``:
#: 5 x 4 positions at 80 mm pitch, stems 75-175 mm (Alami Mchichi 2018, §5.5).
SEED004_GRID = BallGridFile(
    kind="samba-ball-grid",
    x_mm=[-160.0, -80.0, 0.0, 80.0, 160.0],
    y_mm=[-120.0, -40.0, 40.0, 120.0],
    stems_mm=[75.0, 100.0, 125.0, 150.0, 175.0],
)


class _Ball(_Strict):
    id: str = Field(min_length=1)
    centre_mm: tuple[float, float, float]


class BallsFile(_Strict):
    """Balls already placed (step 2 only)."""

    kind: Literal["samba-balls"]
    balls: list[_Ball] = Field(min_length=1)
    scale_bar: ScaleBarPlacement = ScaleBarPlacement()

    @model_validator(mode="after")
    def _unique(self):
        ids = [b.id for b in self.balls] + list(self.scale_bar.ends)
        dup = sorted({i for i in ids if ids.count(i) > 1})
        if dup:
            raise ValueError(f"ball id(s) used twice (scale-bar ends included): {', '.join(dup)}")
        return self


def load_validated(path: str | Path, label: str, model: type[BaseModel]):
    """Read a YAML/JSON document strictly and validate it with a pydantic model; errors
    name the file and the field."""
    p = Path(path)
    data = load_document(p, label)
    try:
        return model.model_validate(data)
    except ValidationError as err:
        raise InputFileError(describe_validation_error(str(p), label, err)) from None


def load_ball_grid(path: str | Path) -> BallGridFile:
    """Read a ``samba-ball-grid`` YAML file; errors name the file and the field."""
    return load_validated(path, "SAMBA ball grid", BallGridFile)


def load_balls(path: str | Path) -> BallsFile:
    """Read a ``samba-balls`` YAML file; errors name the file and the field."""
    return load_validated(path, "SAMBA balls", BallsFile)


def read_indexations(path: str | Path) -> np.ndarray:
    """Candidate (B, C) indexations from a CSV with columns ``B,C`` (degrees), (N, 2)."""
    table = read_csv_table(path, required=["B", "C"])
    pairs = np.column_stack([table.floats("B"), table.floats("C")])
    return _unique_pairs(pairs, f"{path}")


def axis_grid(spec: str, option: str) -> np.ndarray:
    """Angles from ``"start:stop:step"`` (stop included) or a comma list, degrees.

    >>> axis_grid("-90:90:45", "--b-grid").tolist()
    [-90.0, -45.0, 0.0, 45.0, 90.0]
    >>> axis_grid("0,120,240", "--c-grid").tolist()
    [0.0, 120.0, 240.0]
    """
    text = str(spec).strip()
    try:
        if ":" in text:
            start, stop, step = (float(v) for v in text.split(":"))
            if not step > 0 or stop < start:
                raise ValueError
            count = int(np.floor((stop - start) / step + 1e-9)) + 1
            values = start + step * np.arange(count)
        else:
            values = np.array([float(v) for v in text.split(",") if v.strip()])
    except ValueError:
        raise InputError(
            f"{option} {spec!r}: give start:stop:step with step > 0 and stop >= start, "
            "or a comma-separated list of degrees"
        ) from None
    if values.size == 0 or not np.all(np.isfinite(values)):
        raise InputError(f"{option} {spec!r}: no finite angle")
    return values


def default_indexations() -> np.ndarray:
    """450 candidate (B, C) pairs: B from −90° to 90° by 7.5°, C from 0° to 340° by 20°.

    Seed 004 draws its 450 candidates "uniformly" without listing them (digest 004 §7
    item 2); this 25 × 18 grid is the stated assumption.
    """
    b, c = np.meshgrid(np.linspace(-90.0, 90.0, 25), np.arange(0.0, 360.0, 20.0), indexing="ij")
    return np.column_stack([b.ravel(), c.ravel()])


def _unique_pairs(pairs: np.ndarray, where: str) -> np.ndarray:
    _, first = np.unique(np.round(pairs, 9), axis=0, return_index=True)
    if len(first) != len(pairs):
        raise InputError(f"{where}: a (B, C) indexation is listed twice; list each once")
    return pairs


def grid_indexations(b_values: np.ndarray, c_values: np.ndarray) -> np.ndarray:
    """Every (B, C) of two axis grids, B-major, (len(b)·len(c), 2)."""
    b, c = np.meshgrid(b_values, c_values, indexing="ij")
    return _unique_pairs(np.column_stack([b.ravel(), c.ravel()]), "--b-grid/--c-grid")
