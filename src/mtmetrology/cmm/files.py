"""Ball-plate, probe-set and plate-position files, and ball-plate records.

Plate (YAML or JSON)::

    kind: ball-plate
    balls:                                   # calibrated centres in the plate frame, mm
      - {id: "00", x_mm: 0.0, y_mm: 0.0, z_mm: 0.0}
      - {id: "01", x_mm: 133.0, y_mm: 0.0, z_mm: 0.0}
    u_mm: 0.0005                             # standard uncertainty of each coordinate
    covariance_mm2: null                     # or the full (3n x 3n) covariance, mm²,
                                             # ordered x0 y0 z0 x1 ... as the balls
    certificate: {temperature_C: 20.0, cte_per_K: 11.5e-6}      # optional

Probe set::

    kind: probe-set
    probes:                                  # stylus-tip centre relative to the machine's
      - {id: P0, offset_mm: [0, 0, -150]}    # reference point: the tool vector, mm

Plate positions (for ``mtm cmm simulate``)::

    kind: ballplate-positions
    positions:
      - {id: H1, origin_mm: [300, 250, 100], rotation_deg: [0, 0, 0], probes: [P0, P1]}

``rotation_deg`` are fixed-axis angles (about machine X, then Y, then Z) of the plate frame;
``origin_mm`` the machine position of the plate origin.

Records CSV: ``position,ball,probe,X,Y,Z`` — the axis readings (mm) that put the named
stylus's tip centre at the ball centre.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from mtmetrology.io.covariance import symmetric, symmetric_covariance
from mtmetrology.io.documents import load_document
from mtmetrology.io.files import InputFileError
from mtmetrology.io.schema import describe_validation_error
from mtmetrology.io.tables import read_csv_table, write_csv_table

__all__ = [
    "BallPlate",
    "BallPlateRecords",
    "PlatePosition",
    "PositionSet",
    "ProbeSet",
    "load_plate",
    "load_positions",
    "load_probes",
    "probe_tools",
    "read_records",
    "rotation_matrix",
    "validate_records",
    "write_records",
]

#: Fewest balls per position: three non-collinear points fix a plate pose.
MIN_BALLS_PER_POSITION = 3


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


def _unique_ids(ids: list[str], what: str) -> None:
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise ValueError(f"{what} id(s) listed twice: {', '.join(dup)}")


class BallSpec(_Strict):
    id: str = Field(min_length=1)
    x_mm: float
    y_mm: float
    z_mm: float = 0.0


class CertificateSpec(_Strict):
    temperature_C: float | None = None
    cte_per_K: float | None = Field(default=None, ge=0)


class BallPlate(_Strict):
    """A calibrated ball plate: ball centres in the plate frame with their uncertainty."""

    kind: Literal["ball-plate"]
    balls: list[BallSpec] = Field(min_length=3)
    u_mm: float | None = Field(default=None, gt=0)
    covariance_mm2: list[list[float]] | None = None
    certificate: CertificateSpec | None = None

    @model_validator(mode="after")
    def _check(self):
        _unique_ids([b.id for b in self.balls], "ball")
        if (self.u_mm is None) == (self.covariance_mm2 is None):
            raise ValueError("give exactly one of u_mm and covariance_mm2")
        if self.covariance_mm2 is not None:
            n = 3 * len(self.balls)
            c = np.asarray(self.covariance_mm2, dtype=float)
            if c.shape != (n, n):
                raise ValueError(f"covariance_mm2 must be {n}x{n} (3 per ball)")
            try:
                c = symmetric_covariance(c, "covariance_mm2")
            except InputFileError as err:
                raise ValueError(str(err)) from None
            if np.linalg.eigvalsh(c).min() <= 0:
                raise ValueError("covariance_mm2 is not positive definite")
        return self

    @property
    def ids(self) -> tuple[str, ...]:
        return tuple(b.id for b in self.balls)

    @property
    def coordinates(self) -> np.ndarray:
        """Calibrated centres, shape (n_balls, 3), mm."""
        return np.array([[b.x_mm, b.y_mm, b.z_mm] for b in self.balls])

    @property
    def covariance(self) -> np.ndarray:
        """Covariance of the stacked coordinates, shape (3n, 3n), mm²."""
        if self.covariance_mm2 is not None:
            return symmetric(self.covariance_mm2)  # checked by _check
        return np.eye(3 * len(self.balls)) * self.u_mm**2


class ProbeSpec(_Strict):
    id: str = Field(min_length=1)
    offset_mm: tuple[float, float, float]


class ProbeSet(_Strict):
    """Styli: the tip-centre offset of each from the machine's reference point."""

    kind: Literal["probe-set"]
    probes: list[ProbeSpec] = Field(min_length=1)

    @model_validator(mode="after")
    def _unique(self):
        _unique_ids([p.id for p in self.probes], "probe")
        return self

    @property
    def ids(self) -> tuple[str, ...]:
        return tuple(p.id for p in self.probes)

    def offsets(self, ids) -> np.ndarray:
        """Offsets (n, 3), mm, of the probes named in ``ids``."""
        table = {p.id: p.offset_mm for p in self.probes}
        return np.array([table[i] for i in ids], dtype=float)


class PlatePosition(_Strict):
    id: str = Field(min_length=1)
    origin_mm: tuple[float, float, float]
    rotation_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    probes: list[str] = Field(min_length=1)


class PositionSet(_Strict):
    """Plate positions of a (simulated) campaign."""

    kind: Literal["ballplate-positions"]
    positions: list[PlatePosition] = Field(min_length=1)

    @model_validator(mode="after")
    def _unique(self):
        _unique_ids([p.id for p in self.positions], "position")
        return self


def rotation_matrix(angles_rad) -> np.ndarray:
    """``R = R_z(c) R_y(b) R_x(a)``: fixed-axis rotations about X, then Y, then Z.

    Examples
    --------
    >>> np.round(rotation_matrix([0.0, 0.0, np.pi / 2]) @ [1.0, 0.0, 0.0], 12)
    array([0., 1., 0.])
    """
    a, b, c = angles_rad
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    rx = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
    ry = np.array([[cb, 0, sb], [0, 1, 0], [-sb, 0, cb]])
    rz = np.array([[cc, -sc, 0], [sc, cc, 0], [0, 0, 1]])
    return rz @ ry @ rx


def _load(path, model, what: str):
    doc = load_document(path, what)
    try:
        return model.model_validate(doc)
    except ValidationError as err:
        raise InputFileError(
            describe_validation_error(str(path), what, err).replace("\n ", ";")
        ) from None


def load_plate(path: str | Path) -> BallPlate:
    """Read and validate a ball-plate file (see the module notes)."""
    return _load(path, BallPlate, "ball plate")


def load_probes(path: str | Path) -> ProbeSet:
    """Read and validate a probe-set file."""
    return _load(path, ProbeSet, "probe set")


def load_positions(path: str | Path, probes: ProbeSet | None = None) -> PositionSet:
    """Read a plate-position file; with ``probes`` every probe id is checked."""
    pos = _load(path, PositionSet, "plate positions")
    if probes is not None:
        for k, p in enumerate(pos.positions):
            for pid in p.probes:
                if pid not in probes.ids:
                    raise InputFileError(
                        f"{path}: positions[{k}].probes: {pid!r} is not in the probe set "
                        f"({', '.join(probes.ids)})"
                    )
    return pos


@dataclass(frozen=True)
class BallPlateRecords:
    """Validated ball-plate indications.

    Attributes
    ----------
    positions, balls, probes : tuple of str, length n
        Plate position, ball id and probe id of each indication.
    readings : ndarray, shape (n, 3)
        X, Y, Z axis readings, mm.
    lines : ndarray of int
        File line of each indication.
    """

    positions: tuple[str, ...]
    balls: tuple[str, ...]
    probes: tuple[str, ...]
    readings: np.ndarray
    lines: np.ndarray

    @property
    def position_ids(self) -> tuple[str, ...]:
        """Distinct positions in order of first appearance."""
        return tuple(dict.fromkeys(self.positions))

    def __len__(self) -> int:
        return len(self.balls)

    def subset(self, mask: np.ndarray) -> BallPlateRecords:
        idx = np.flatnonzero(mask)
        return BallPlateRecords(
            tuple(self.positions[i] for i in idx),
            tuple(self.balls[i] for i in idx),
            tuple(self.probes[i] for i in idx),
            self.readings[idx],
            self.lines[idx],
        )


def validate_records(
    records: BallPlateRecords, plate: BallPlate, probes: ProbeSet, source: str
) -> None:
    """Every ball on the plate, every probe in the probe set, >= 3 balls per position.

    Raises
    ------
    InputFileError
        Naming the file and line.
    """
    for i, (b, p) in enumerate(zip(records.balls, records.probes, strict=True)):
        if b not in plate.ids:
            raise InputFileError(
                f"{source}, line {records.lines[i]}: ball {b!r} is not on the plate "
                f"(balls: {', '.join(plate.ids[:6])}{' ...' if len(plate.ids) > 6 else ''})"
            )
        if p not in probes.ids:
            raise InputFileError(
                f"{source}, line {records.lines[i]}: probe {p!r} is not in the probe set "
                f"({', '.join(probes.ids)})"
            )
    for pos in records.position_ids:
        balls = {b for b, q in zip(records.balls, records.positions, strict=True) if q == pos}
        if len(balls) < MIN_BALLS_PER_POSITION:
            raise InputFileError(
                f"{source}: position {pos!r} has {len(balls)} distinct ball(s); at least "
                f"{MIN_BALLS_PER_POSITION} are needed to fix the plate pose"
            )


def read_records(
    path: str | Path, plate: BallPlate | None = None, probes: ProbeSet | None = None
) -> BallPlateRecords:
    """Read ``position,ball,probe,X,Y,Z`` (mm); validated against plate and probes if given.

    Raises
    ------
    InputFileError
        Missing column, a non-number or NaN (with file and line), a ball not on the plate, a
        probe not in the probe set, or a position with fewer than three balls.
    """
    table = read_csv_table(path, required=["position", "ball", "probe", "X", "Y", "Z"])
    readings = np.column_stack([table.floats(a) for a in "XYZ"])
    rec = BallPlateRecords(
        tuple(table.strings("position")),
        tuple(table.strings("ball")),
        tuple(table.strings("probe")),
        readings,
        table.lines,
    )
    if plate is not None and probes is not None:
        validate_records(rec, plate, probes, str(path))
    return rec


#: Columns of a records CSV.
RECORD_COLUMNS = ("position", "ball", "probe", "X", "Y", "Z")


def write_records(path: str | Path, records: BallPlateRecords) -> None:
    """Write records as ``position,ball,probe,X,Y,Z`` (mm, to 1 nm), atomically.

    What :func:`read_records` reads back (readings rounded to 1 nm).
    """
    rows = (
        [p, b, s, *(f"{v:.6f}" for v in q)]
        for p, b, s, q in zip(
            records.positions, records.balls, records.probes, records.readings, strict=True
        )
    )
    write_csv_table(path, list(RECORD_COLUMNS), rows)


def probe_tools(probes: ProbeSet, table) -> np.ndarray:
    """Tool vectors (n, 3), mm, from the ``probe`` column of a table and a probe set.

    Raises
    ------
    InputFileError
        Missing ``probe`` column or a probe id not in the set (file and line named).
    """
    ids = table.strings("probe")
    for i, pid in enumerate(ids):
        if pid not in probes.ids:
            raise InputFileError(
                f"{table.path}, line {table.lines[i]}: probe {pid!r} is not in the probe set "
                f"({', '.join(probes.ids)})"
            )
    return probes.offsets(ids)
