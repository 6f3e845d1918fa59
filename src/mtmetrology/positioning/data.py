"""The neutral ISO 230-2 record: targets, runs, both approaches, and the test conditions.

The CSV holds one reading per line in the standard's layout::

    target,position_mm,run,direction,deviation_um
    1,0.0,1,+,0.8
    1,0.0,1,-,2.1
    ...

``target`` is the index i (1 … m), ``position_mm`` the target position P_i, ``run`` the
index j (1 … n), ``direction`` the approach (``+`` or ``↑`` positive, ``-``, ``−`` or ``↓``
negative) and ``deviation_um`` the positional deviation ``x_ij = P_ij − P_i`` in µm
(ISO 230-2:2014, clause 3).  Lines beginning with ``#`` before the header may state the
test conditions as ``# key: value`` (the keys of :class:`Conditions`); a conditions file
(YAML or JSON, ``kind: iso230-2-conditions``) states them instead and wins.

Everything is checked at the door: a missing column, a value that is not a number, an
unknown direction, a reading given twice, a target whose position changes, targets not
strictly increasing with their index, a run with no readings in one direction, a run that
misses a target, fewer than five runs per direction — each refused with one line naming the
file and the line, field, run or target.
"""

from __future__ import annotations

import csv
import math
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import numpy as np
import yaml

from mtmetrology.errors import InputError
from mtmetrology.io.documents import load_document
from mtmetrology.positioning.parameters import MIN_RUNS
from mtmetrology.units import from_internal, to_internal

__all__ = ["COLUMNS", "CONDITIONS_KIND", "Conditions", "PositioningTest", "read_test"]

COLUMNS = ("target", "position_mm", "run", "direction", "deviation_um")
CONDITIONS_KIND = "iso230-2-conditions"
_UP, _DOWN = {"+", "↑", "up"}, {"-", "−", "↓", "down"}


@dataclass(frozen=True)
class Conditions:
    """Test conditions of an ISO 230-2 run (what the standard asks to be reported).

    Attributes
    ----------
    axis : str
        The linear axis tested (``X``, ``Y``, ``Z`` …).
    travel_mm : list of float or None
        The axis travel (low, high).
    approach : str
        The test cycle: ``linear`` (standard cycle) or ``pilgrim`` (step cycle).
    overrun_mm : float or None
        The overrun beyond each end target before the reversal.
    air_temperature_C, air_pressure_Pa, humidity_percent : float
        Air conditions along the beam path.
    material_temperatures_C : list of float
        Material (machine) temperature sensors; their mean is the material temperature.
    expansion_scale_per_K : float
        Expansion coefficient of the machine's scale (its positioning reference).
    expansion_material_per_K : float
        Expansion coefficient of the material the positions are normalised for (NDE).
    wavelength_nm : float
        Vacuum wavelength of the laser.
    air_compensated : bool
        Whether the deviations as given are already corrected for the air refractive index
        (True: the instrument's weather station did it; no air correction is applied).
    nde_applied : bool
        Whether the deviations as given are already normalised to 20 °C.
    datum_mm : float or None
        Target position at which the laser was zeroed (the first target if None).
    """

    axis: str = "X"
    travel_mm: list | None = None
    approach: str = "linear"
    overrun_mm: float | None = None
    air_temperature_C: float = 20.0
    air_pressure_Pa: float = 101325.0
    humidity_percent: float = 50.0
    material_temperatures_C: list = field(default_factory=lambda: [20.0])
    expansion_scale_per_K: float = 11.5e-6
    expansion_material_per_K: float = 11.5e-6
    wavelength_nm: float = 632.991
    air_compensated: bool = False
    nde_applied: bool = False
    datum_mm: float | None = None

    @property
    def material_C(self) -> float:
        """Mean material temperature, °C."""
        return float(np.mean(self.material_temperatures_C))

    def to_dict(self) -> dict:
        """The JSON form (the keys of a conditions file)."""
        return asdict(self)

    @classmethod
    def from_mapping(cls, doc: dict, source: str) -> Conditions:
        """Conditions from a mapping, each key checked (one line naming a bad one)."""
        known = {f.name: f for f in fields(cls)}
        values = {}
        for key, value in doc.items():
            if key in ("kind", "version"):
                continue
            if key not in known:
                raise InputError(f"{source}: {key}: not a test condition ({', '.join(known)})")
            values[key] = _condition(key, value, source)
        if "axis" in values and not (isinstance(values["axis"], str) and len(values["axis"]) == 1):
            raise InputError(f"{source}: axis: {values['axis']!r} is not one axis letter")
        if "axis" in values:
            values["axis"] = values["axis"].upper()
        if values.get("approach", "linear") not in ("linear", "pilgrim"):
            raise InputError(f"{source}: approach: {values['approach']!r} is not linear or pilgrim")
        return cls(**values)


def _condition(key: str, value, source: str):
    if key in ("axis", "approach"):
        return str(value)
    if key in ("air_compensated", "nde_applied"):
        if not isinstance(value, bool):
            raise InputError(f"{source}: {key}: {value!r} is not true or false")
        return value
    if value is None and key in ("overrun_mm", "datum_mm", "travel_mm"):
        return None
    if key in ("travel_mm", "material_temperatures_C"):
        seq = value if isinstance(value, list) else [value]
        return [_finite(v, f"{source}: {key}") for v in seq]
    return _finite(value, f"{source}: {key}")


def _finite(value, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError(f"{where}: {value!r} is not a finite number")
    return float(value)


@dataclass(frozen=True)
class PositioningTest:
    """One ISO 230-2 test of one linear axis.

    Attributes
    ----------
    targets : ndarray, shape (m,)
        Target positions P_i, mm, strictly increasing.
    deviations : ndarray, shape (m, n, 2)
        ``x_ij`` in mm (internal units), approach ↑ then ↓.
    conditions : Conditions
    source : str
    """

    targets: np.ndarray
    deviations: np.ndarray
    conditions: Conditions = field(default_factory=Conditions)
    source: str = "<test>"

    @property
    def runs(self) -> int:
        """Runs per direction."""
        return int(self.deviations.shape[1])

    def write(self, path: str | Path) -> None:
        """Write the neutral CSV, the conditions as ``# key: value`` lines above the header."""
        lines = [f"# {k}: {_flow(v)}" for k, v in self.conditions.to_dict().items()]
        lines.append(",".join(COLUMNS))
        x_um = from_internal(self.deviations, "µm")
        for i, p in enumerate(self.targets):
            for j in range(self.runs):
                for d, sign in enumerate("+-"):
                    lines.append(f"{i + 1},{p:.6f},{j + 1},{sign},{x_um[i, j, d]:.6f}")
        Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def _flow(value) -> str:
    """One YAML scalar or flow list on one line (``[0.0, 1000.0]``, ``null``, ``true``)."""
    return yaml.safe_dump(value, default_flow_style=True).strip().removesuffix("...").strip()


def _header_conditions(comments: list[str], source: str) -> dict:
    if not comments:
        return {}
    try:
        doc = yaml.safe_load("\n".join(comments))
    except yaml.YAMLError as err:
        raise InputError(f"{source}: header conditions: {err.problem}") from None
    if not isinstance(doc, dict):
        raise InputError(f"{source}: header conditions: not 'key: value' lines")
    return doc


def read_test(path: str | Path, conditions: str | Path | None = None) -> PositioningTest:
    """Read the neutral CSV (and a conditions file) into a :class:`PositioningTest`.

    Parameters
    ----------
    path : path-like
        The CSV (module notes for the layout).
    conditions : path-like, optional
        YAML or JSON conditions (``kind: iso230-2-conditions``); the CSV header's otherwise.

    Returns
    -------
    PositioningTest

    Raises
    ------
    InputError
        One line naming the file and the line, field, run or target at fault (module notes).
    """
    src = str(path)
    p = Path(path)
    if not p.is_file():
        raise InputError(f"{src}: file not found (expected an ISO 230-2 CSV)")
    comments, rows = [], []
    with p.open(encoding="utf-8-sig", newline="") as fh:
        header = None
        for lineno, row in enumerate(csv.reader(fh), start=1):
            if not row or not "".join(row).strip():
                continue
            if header is None and row[0].lstrip().startswith("#"):
                comments.append(",".join(row).lstrip()[1:].strip())
                continue
            if header is None:
                header = [h.strip() for h in row]
                missing = [c for c in COLUMNS if c not in header]
                if missing:
                    raise InputError(f"{src}, line {lineno}: column '{missing[0]}' missing")
                idx = [header.index(c) for c in COLUMNS]
                continue
            if len(row) != len(header):
                raise InputError(
                    f"{src}, line {lineno}: {len(row)} fields, the header has {len(header)}"
                )
            rows.append((lineno, [row[k].strip() for k in idx]))
    if header is None or not rows:
        raise InputError(f"{src}: no readings (header {','.join(COLUMNS)} and one line each)")
    cond = _header_conditions(comments, src)
    where = src
    if conditions is not None:
        cond = load_document(conditions, "ISO 230-2 conditions")
        where = str(conditions)
        if not isinstance(cond, dict) or cond.get("kind") != CONDITIONS_KIND:
            raise InputError(f"{where}: kind: must be {CONDITIONS_KIND!r}")
    conds = Conditions.from_mapping(cond, where)
    positions: dict[int, tuple[float, int]] = {}
    readings: dict[tuple[int, int, int], float] = {}
    for lineno, (t, pos, run, direction, dev) in rows:
        at = f"{src}, line {lineno}"
        i = _integer(t, at, "target")
        j = _integer(run, at, "run")
        if direction in _UP:
            d = 0
        elif direction in _DOWN:
            d = 1
        else:
            raise InputError(f"{at}: field 'direction': {direction!r} is not + or -")
        position = _number(pos, at, "position_mm")
        value = _number(dev, at, "deviation_um")
        if i in positions and positions[i][0] != position:
            raise InputError(
                f"{at}: field 'position_mm': target {i} at {position:g} mm, at "
                f"{positions[i][0]:g} mm on line {positions[i][1]}"
            )
        positions.setdefault(i, (position, lineno))
        if (i, j, d) in readings:
            raise InputError(f"{at}: target {i}, run {j}, direction {direction}: given twice")
        readings[(i, j, d)] = value
    index = sorted(positions)
    if index != list(range(1, len(index) + 1)):
        gap = next(k for k in range(1, len(index) + 2) if k not in positions)
        raise InputError(f"{src}: target {gap} missing (targets are numbered 1 to m)")
    targets = np.array([positions[i][0] for i in index])
    bad = np.flatnonzero(np.diff(targets) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise InputError(
            f"{src}: targets not monotonic: target {k + 1} at {targets[k]:g} mm after target "
            f"{k} at {targets[k - 1]:g} mm (line {positions[k + 1][1]})"
        )
    runs = sorted({j for _, j, _ in readings})
    if runs != list(range(1, len(runs) + 1)):
        gap = next(k for k in range(1, len(runs) + 2) if k not in runs)
        raise InputError(f"{src}: run {gap} missing (runs are numbered 1 to n)")
    for j in runs:
        for d, name in ((0, "+"), (1, "-")):
            have = [i for i in index if (i, j, d) in readings]
            if not have:
                raise InputError(f"{src}: run {j} has no readings in direction {name}")
            if len(have) != len(index):
                miss = next(i for i in index if (i, j, d) not in readings)
                raise InputError(f"{src}: run {j}, direction {name}: target {miss} missing")
    if len(runs) < MIN_RUNS:
        raise InputError(
            f"{src}: {len(runs)} runs per direction; ISO 230-2 requires {MIN_RUNS} at least"
        )
    x = np.empty((len(index), len(runs), 2))
    for (i, j, d), v in readings.items():
        x[i - 1, j - 1, d] = v
    return PositioningTest(targets, to_internal(x, "µm"), conds, src)


def _integer(text: str, at: str, name: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise InputError(f"{at}: field '{name}': {text!r} is not a whole number") from None
    if value < 1:
        raise InputError(f"{at}: field '{name}': {value} < 1")
    return value


def _number(text: str, at: str, name: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InputError(f"{at}: field '{name}': {text!r} is not a number") from None
    if not math.isfinite(value):
        raise InputError(f"{at}: field '{name}': {text!r} is not finite")
    return value
