"""The probing records of the repeatability and hysteresis tests, and their workflows.

:func:`fit_repeatability_file` (``mtm repeatability fit``) reads replicated probing
records, computes the per-target statistics (optionally after a cubic drift and with
sliding windows) and fits the repeatability models (Sepahi Boroujeni (2021), eqs. 4-1,
4-2); :func:`hysteresis_from_file` (``mtm repeatability hysteresis``) evaluates the
probing or axis hysteresis (eqs. 4-3, 4-4) of ring-gauge records.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.io import read_csv_table
from mtmetrology.omm.choices import MIN_TARGETS_PER_COEFFICIENT
from mtmetrology.omm.hysteresis import (
    HYSTERESIS_KINDS,
    HysteresisResult,
    hysteresis_errors,
    radial_projection,
)
from mtmetrology.omm.notebook import OMMNotebookRepr
from mtmetrology.omm.repeatability import (
    TargetStatistics,
    factors_from_file_units,
    target_statistics,
)
from mtmetrology.omm.repeatability_model import (
    RepeatabilityModel,
    fit_repeatability_model,
)
from mtmetrology.omm.repeatability_windows import WindowStatistics, window_statistics
from mtmetrology.units import to_internal

__all__ = [
    "CENTRE_COLUMNS",
    "READING_COLUMNS",
    "RECORD_COLUMNS",
    "RepeatabilityFit",
    "fit_repeatability_file",
    "hysteresis_from_file",
    "read_hysteresis_records",
    "read_repeatability_records",
]

RECORD_COLUMNS = ("target", "phi", "theta", "B", "C", "X_T", "Y_T", "Z_T", "i", "j", "k")
READING_COLUMNS = ("X", "Y", "Z", "time")
CENTRE_COLUMNS = ("centre_X", "centre_Y", "centre_Z")

#: condition label -> (test, affected): H = mean r (affected) − mean r (reference).
_CONDITIONS = {
    label: (kind, flag)
    for kind, labels in HYSTERESIS_KINDS.items()
    for label, flag in zip(labels, (True, False), strict=True)
}


def read_repeatability_records(path: str | Path) -> dict:
    """The keyword arguments of :func:`~mtmetrology.omm.repeatability.target_statistics`
    from a records CSV (columns :data:`RECORD_COLUMNS`, :data:`READING_COLUMNS`, optional
    :data:`CENTRE_COLUMNS`); the surface normal is −(i, j, k)/‖(i, j, k)‖."""
    table = read_csv_table(path, required=RECORD_COLUMNS + READING_COLUMNS)
    factors = factors_from_file_units(
        *(table.floats(c) for c in ("phi", "theta", "B", "C", "X_T", "Y_T", "Z_T"))
    )
    approach = table.vectors("ijk")
    length = np.linalg.norm(approach, axis=1)
    if np.any(length == 0):
        line = table.lines[int(np.flatnonzero(length == 0)[0])]
        raise InputError(f"{path}, line {line}: the approach (i, j, k) is the zero vector")
    centre = None
    if any(table.has(c) for c in CENTRE_COLUMNS):
        centre = table.vectors(CENTRE_COLUMNS)
    return dict(
        target=table.strings("target"),
        factors=factors,
        readings=table.vectors("XYZ"),
        normal=-approach / length[:, None],  # the probe approaches along −n̂
        time=table.floats("time"),
        centre=centre,
        where=str(path),
    )


@dataclass(frozen=True)
class RepeatabilityFit(OMMNotebookRepr):
    """The repeatability models fitted to one records file (:func:`fit_repeatability_file`).

    Attributes
    ----------
    model : RepeatabilityModel
    statistics : TargetStatistics
    windows : WindowStatistics or None
        σ in sliding windows, when asked for.
    window_from : int
        Iteration where the first window starts.
    source : str
        The records file.
    """

    model: RepeatabilityModel
    statistics: TargetStatistics
    windows: WindowStatistics | None
    window_from: int
    source: str

    @property
    def resolution_warnings(self) -> list[str]:
        """Targets with a zero variance of a coordinate (approach slightly off the axes)."""
        s = self.statistics
        return [t for t, z in zip(s.targets, s.zero_variance, strict=True) if z.any()]

    def to_dict(self) -> dict:
        """The ``repeatability-model`` document with its statistics and windows (µm, µm²)."""
        document = self.model.to_dict()
        document["source"] = self.source
        document["statistics"] = self.statistics.to_dict()
        if self.windows is not None:
            document["windows"] = {"first_iteration": self.window_from, **self.windows.to_dict()}
        document["resolution_warnings"] = self.resolution_warnings
        json.dumps(document, allow_nan=False)  # a NaN is never a result
        return document


def fit_repeatability_file(
    records: str | Path,
    *,
    holdout: float = 0.15,
    seed: int = 0,
    allow_few_targets: bool = False,
    drift: str = "none",
    window: int | None = None,
    window_from: int = 2,
) -> RepeatabilityFit:
    """Fit the probing-repeatability models to a records file (Sepahi Boroujeni (2021),
    eqs. 4-1 and 4-2).

    Parameters
    ----------
    records : path
        One row per touch (:func:`read_repeatability_records`).
    holdout : float
        Fraction of the targets held out for the validation errors.
    seed : int
        Seed of the held-out draw.
    allow_few_targets : bool
        Fit with fewer than
        :data:`~mtmetrology.omm.choices.MIN_TARGETS_PER_COEFFICIENT` targets per coefficient.
    drift : {"none", "cubic"}
        Remove a cubic drift in time from each target's series first.
    window, window_from : int
        σ in windows of ``window`` touches from iteration ``window_from`` (None: none).

    Returns
    -------
    RepeatabilityFit
    """
    data = read_repeatability_records(records)
    stats = target_statistics(**data, drift=drift)
    windows = None
    if window is not None:
        windows = window_statistics(
            data["target"],
            data["readings"],
            data["normal"],
            data["time"],
            window=window,
            first_iteration=window_from,
            where=data["where"],
        )
    model = fit_repeatability_model(
        stats,
        holdout=holdout,
        seed=seed,
        min_targets_per_coefficient=0.0 if allow_few_targets else MIN_TARGETS_PER_COEFFICIENT,
    )
    return RepeatabilityFit(model, stats, windows, window_from, str(records))


def read_hysteresis_records(path: str | Path):
    """ψ (rad), r (mm), the affected flag of each touch and the test of a ring-gauge file.

    Columns ``psi`` (deg), ``condition`` (direct/hysteresis or +/-), and ``r`` or ``X, Y``
    (relative to the ring centre, r = X cos ψ + Y sin ψ).
    """
    table = read_csv_table(path, required=("psi", "condition"))
    labels = table.strings("condition")
    for label, line in zip(labels, table.lines, strict=True):
        if label not in _CONDITIONS:
            raise InputError(
                f"{path}, line {line}: column 'condition' holds {label!r}; use direct and "
                "hysteresis (probing test) or + and - (axis test)"
            )
    kinds = {_CONDITIONS[label][0] for label in labels}
    if len(kinds) != 1:
        raise InputError(
            f"{path}: column 'condition' mixes the probing test (direct, hysteresis) and the "
            "axis test (+, -); give each test its own file"
        )
    psi = to_internal(table.floats("psi"), "deg")
    if table.has("r") == (table.has("X") or table.has("Y")):
        raise InputError(
            f"{path}: give either the radial projection in column 'r' or the readings in "
            "columns 'X' and 'Y' (relative to the ring centre), not both"
        )
    if table.has("r"):
        radius = table.floats("r")
    else:
        radius = radial_projection(table.floats("X"), table.floats("Y"), psi)
    affected = np.array([_CONDITIONS[label][1] for label in labels])
    return psi, radius, affected, kinds.pop()


def hysteresis_from_file(records: str | Path, *, p: float = 0.95) -> HysteresisResult:
    """Probing or axis hysteresis of a ring-gauge records file (eqs. 4-3 and 4-4).

    Returns
    -------
    HysteresisResult
        With ``source`` the records file.
    """
    psi, radius, affected, kind = read_hysteresis_records(records)
    result = hysteresis_errors(psi, radius, affected, kind=kind, p=p, where=str(records))
    return replace(result, source=str(records))
