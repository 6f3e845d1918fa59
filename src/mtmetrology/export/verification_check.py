"""The readings of a compensation check (:mod:`mtmetrology.export.verification`) compared
with the predicted residual: is the table's sign and size confirmed on the machine?

Measurement model
-----------------
For each measured component, ``m = r + ε`` if the control applies the table as predicted,
with ``u(ε)² = (U/2)² + u_reading²``: the prediction's standard uncertainty (the
identification's, propagated through the tables) and the reading's (laser, temperature,
repeatability), uncorrelated (JCGM 100:2008 §5.1.2).  The point is *confirmed* when
``|m − r| ≤ U_c = 2 sqrt((U/2)² + u_reading²)`` (k = 2).

The table's correction at the point is ``c = r − e`` (the residual is the error plus the
correction).  A control that applies ``κ`` times the table leaves ``m = e + κ c``:

- ``κ = 1`` the table as predicted: ``m = r``;
- ``κ = −1`` the sign flipped: ``m = e − c = 2e − r``, about ``2e`` where the table removes
  the error (``r ≈ 0``) — the residual is twice the error;
- ``κ = 0`` the table not applied: ``m = e``.

A component *discriminates* when ``|c| > 2 U_c``: the intervals ``±U_c`` about ``r`` and
about ``e`` do not overlap, nor do those about ``r`` and ``2e − r``.  Over the
discriminating components κ is estimated by weighted least squares,
``κ̂ = Σ w c (m − e) / Σ w c²`` with ``w = 1/u(ε)²``, ``u(κ̂) = (Σ w c²)^(−1/2)`` (the
components taken as independent: the identification's uncertainty, common to all points,
makes this optimistic).  The overall verdict:

``confirmed``
    κ̂ agrees with 1 (``|κ̂ − 1| ≤ 2 u(κ̂)``) and the deviations ``m − r`` agree with their
    uncertainty: ``χ² = Σ ((m − r)/u(ε))²`` is not beyond the 99 % point of χ² with as many
    degrees of freedom as measured components (a single point outside ``r ± U_c`` is
    expected about once in twenty).  A correct table whose uncertainties are as stated is
    thus confirmed about 94 % of the time (0.95 × 0.99; 189 of 200 simulated campaigns in
    ``tests/export/test_verification_check.py``);
``residual not confirmed``
    κ̂ agrees with 1 but χ² does not: the table acts with its sign and size, the residual
    differs from the prediction (errors the model does not hold, temperature, a reading);
``sign error``
    κ̂ agrees with −1;
``table not active``
    κ̂ agrees with 0;
``size not confirmed``
    κ̂ agrees with none of them (the control applies κ̂ times the table: units, a factor);
``inconclusive``
    no component discriminates: the corrections at the check points are smaller than the
    uncertainty; choose check positions where the table corrects more.

The classification of a single point uses the same ``U_c`` about ``2e − r`` and ``e``
(their own uncertainty is not known; it is indicative — the confirmation against
``r ± U_c`` is the statement).

References
----------
JCGM 100:2008, §5.1.2 (combination of uncorrelated uncertainties).
ISO 230-2:2014 (deviation of position: actual position reached minus target position).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.io.files import InputFileError
from mtmetrology.io.tables import Table, read_csv_table

__all__ = ["CHECK_KIND", "VERDICTS", "VerificationCheck", "compare_readings"]

CHECK_KIND = "compensation-verification"
VERSION = 1
VERDICTS = (
    "confirmed",
    "residual not confirmed",
    "sign error",
    "table not active",
    "size not confirmed",
    "inconclusive",
)
#: Probability of the χ² point above which the deviations m − r disagree with u(ε).
CHI2_LEVEL = 0.99
_COMPONENTS = "xyz"


@dataclass(frozen=True)
class VerificationCheck:
    """The readings of a compensation check compared with the prediction.

    Attributes
    ----------
    source : str
        The readings file.
    verdict : str
        One of :data:`VERDICTS` (module notes).
    factor : float or None
        κ̂, the multiple of the table the control applies, over the discriminating
        components; ``factor_u`` its standard uncertainty.
    chi2 : float
        Σ ((m − r)/u(ε))² over the measured components; ``chi2_limit`` its 99 % point.
    points : list of dict
        Per measured point: ``point``, ``axis``, ``verdict`` and ``components``, each with
        ``component``, ``measured_um``, ``r_um``, ``e_um``, ``correction_um`` (r − e),
        ``U_um`` (the prediction's, k = 2, None if not stated), ``u_reading_um``,
        ``U_c_um`` (combined, k = 2), ``discriminates`` and ``verdict``.
    not_measured : list of str
        Points of the file without a reading.
    notes : list of str
    """

    source: str
    verdict: str
    factor: float | None
    factor_u: float | None
    chi2: float
    chi2_limit: float
    points: list
    not_measured: list = field(default_factory=list)
    notes: list = field(default_factory=list)

    @property
    def confirmed(self) -> bool:
        return self.verdict == "confirmed"

    def to_dict(self) -> dict:
        counts = {v: 0 for v in VERDICTS}
        for p in self.points:
            counts[p["verdict"]] += 1
        return {
            "kind": CHECK_KIND,
            "version": VERSION,
            "source": self.source,
            "verdict": self.verdict,
            "confirmed": self.confirmed,
            "factor": self.factor,
            "factor_u": self.factor_u,
            "chi2": self.chi2,
            "chi2_limit": self.chi2_limit,
            "k": 2,
            "counts": {k: v for k, v in counts.items() if v},
            "points": self.points,
            "not_measured": self.not_measured,
            "notes": self.notes,
        }


def _optional(table: Table, name: str, rows: np.ndarray) -> np.ndarray:
    """A column whose cells may be empty: NaN where empty, the number (checked with its
    line and column) where not."""
    out = np.full(len(table), np.nan)
    if not table.has(name):
        return out
    filled = np.flatnonzero(np.array([c != "" for c in table.strings(name)], bool) & rows)
    if filled.size:
        out[filled] = table.take(filled).floats(name)
    return out


def _point_verdict(m, r, e, big_uc) -> tuple[str, bool]:
    c = r - e
    discriminates = bool(abs(c) > 2 * big_uc)
    if abs(m - r) <= big_uc:
        return "confirmed", discriminates
    if not discriminates:
        return "inconclusive", False
    if abs(m - (2 * e - r)) <= big_uc:
        return "sign error", True
    if abs(m - e) <= big_uc:
        return "table not active", True
    return "size not confirmed", True


def _overall(chi2, limit, factor, factor_u) -> str:
    if factor is None:
        return "inconclusive"
    if abs(factor - 1.0) <= 2 * factor_u:
        return "confirmed" if chi2 <= limit else "residual not confirmed"
    if abs(factor + 1.0) <= 2 * factor_u:
        return "sign error"
    if abs(factor) <= 2 * factor_u:
        return "table not active"
    return "size not confirmed"


def compare_readings(path: str | Path, u_reading_um: float | None = None) -> VerificationCheck:
    """Compare the readings entered in a :data:`TEMPLATE` with the predicted residual.

    Parameters
    ----------
    path : path-like
        The filled template (:func:`template`).
    u_reading_um : float, optional
        Standard uncertainty of a reading, µm, where the row's ``u_reading_um`` is empty.

    Returns
    -------
    VerificationCheck
        Verdict per point and overall (module notes: the measurement model).

    Raises
    ------
    InputFileError
        A missing column, a cell that is not a number (file, line, column), a measured row
        without a reading uncertainty, no measured deviation at all.
    """
    from scipy.stats import chi2 as chi2_dist

    if u_reading_um is not None and not (math.isfinite(u_reading_um) and u_reading_um >= 0):
        raise InputError(f"--u-reading: {u_reading_um:g} µm must be a number >= 0")
    required = ["point", "axis"] + [f"{q}{c}_um" for q in "rUem" for c in _COMPONENTS]
    table = read_csv_table(path, required=required)
    ids, lines = table.strings("point"), table.strings("axis")
    m = np.column_stack([_optional(table, f"m{c}_um", np.ones(len(table), bool)) for c in "xyz"])
    measured = ~np.isnan(m)
    rows = measured.any(axis=1)
    if not rows.any():
        raise InputFileError(f"{path}: no measured deviation: fill mx_um, my_um or mz_um")
    sub = table.take(np.flatnonzero(rows))
    r = sub.vectors([f"r{c}_um" for c in _COMPONENTS])
    e = sub.vectors([f"e{c}_um" for c in _COMPONENTS])
    big_u = np.column_stack([_optional(table, f"U{c}_um", rows)[rows] for c in _COMPONENTS])
    u_read = _optional(table, "u_reading_um", rows)[rows]
    if (u_read < 0).any():
        i = int(np.argmax(u_read < 0))
        raise InputFileError(f"{path}, line {sub.lines[i]}: column 'u_reading_um' is negative")
    if np.isnan(u_read).any():
        if u_reading_um is None:
            i = int(np.argmax(np.isnan(u_read)))
            raise InputFileError(
                f"{path}, line {sub.lines[i]}: column 'u_reading_um' is empty; fill it or "
                "give --u-reading (standard uncertainty of a reading, µm)"
            )
        u_read = np.where(np.isnan(u_read), u_reading_um, u_read)
    m, measured = m[rows], measured[rows]
    u_pred = np.where(np.isnan(big_u), 0.0, big_u / 2)
    u_eps = np.sqrt(u_pred**2 + u_read[:, None] ** 2)
    if (u_eps[measured] == 0).any():
        i = int(np.argmax((u_eps == 0).any(axis=1) & measured.any(axis=1)))
        raise InputFileError(
            f"{path}, line {sub.lines[i]}: no uncertainty at all (U empty or 0 and "
            "u_reading_um 0): a reading always has one"
        )
    points, sxx, sxy, chi2 = [], 0.0, 0.0, 0.0
    index = np.flatnonzero(rows)
    for i in range(len(index)):
        comps = []
        for j in np.flatnonzero(measured[i]):
            uc = 2 * float(u_eps[i, j])
            verdict, disc = _point_verdict(m[i, j], r[i, j], e[i, j], uc)
            c = float(r[i, j] - e[i, j])
            w = 1.0 / u_eps[i, j] ** 2
            chi2 += float(w * (m[i, j] - r[i, j]) ** 2)
            if disc:
                sxx += w * c * c
                sxy += w * c * float(m[i, j] - e[i, j])
            comps.append(
                {
                    "component": _COMPONENTS[j],
                    "measured_um": float(m[i, j]),
                    "r_um": float(r[i, j]),
                    "e_um": float(e[i, j]),
                    "correction_um": c,
                    "U_um": None if np.isnan(big_u[i, j]) else float(big_u[i, j]),
                    "u_reading_um": float(u_read[i]),
                    "U_c_um": uc,
                    "discriminates": disc,
                    "verdict": verdict,
                }
            )
        worst = max(comps, key=lambda x: abs(x["measured_um"] - x["r_um"]) / x["U_c_um"])
        confirmed = all(x["verdict"] == "confirmed" for x in comps)
        points.append(
            {
                "point": ids[index[i]],
                "axis": lines[index[i]],
                "verdict": "confirmed" if confirmed else worst["verdict"],
                "components": comps,
            }
        )
    n = int(measured.sum())
    limit = float(chi2_dist.ppf(CHI2_LEVEL, n))
    factor = factor_u = None
    if sxx > 0:
        factor, factor_u = sxy / sxx, 1.0 / math.sqrt(sxx)
    notes = []
    if factor is None:
        notes.append(
            "no measured component discriminates (|r - e| <= 2 U_c everywhere): the table "
            "corrects too little at these points to confirm its sign"
        )
    if np.isnan(big_u[measured]).any():
        notes.append("the prediction states no uncertainty (no covariance): U_c is the reading's")
    return VerificationCheck(
        str(path),
        _overall(chi2, limit, factor, factor_u),
        factor,
        factor_u,
        chi2,
        limit,
        points,
        [ids[k] for k in np.flatnonzero(~rows)],
        notes,
    )
