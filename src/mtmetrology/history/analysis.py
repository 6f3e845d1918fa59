"""What the history tells: a parameter's control chart and the long-term covariance.

:func:`parameter_trend` draws the individuals control chart of one error parameter over a
machine's calibrations (ISO 7870-2:2023, Shewhart charts for individual values): centre line
the mean x̄ of the baseline runs, control limits x̄ ± 3 σ̂ with σ̂ = MR̄ / d₂, MR̄ the mean
moving range of consecutive baseline values and d₂ = 2/√π = 1.128 (ranges of two). A point
outside the limits is flagged out of control: a crash, a re-alignment, a compensation
table loaded, or a calibration gone wrong.

:func:`long_term_covariance` is :func:`mtmetrology.identification.long_term.long_term_parameters`
(the same statistic as ``mtm samba long-term``) over the machine's runs in the
database.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from datetime import datetime

import numpy as np
from sqlalchemy import Engine

from mtmetrology.errors import InputError
from mtmetrology.history.drift import DriftResult, fit_drift
from mtmetrology.history.series import (
    machine_model,
    parameter_matrix,
    parameter_series,
    run_covariances,
)
from mtmetrology.identification.long_term import long_term_parameters
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.uncertainty.coverage import DEFAULT_P
from mtmetrology.units import parse_unit

__all__ = [
    "D2",
    "PATTERNS",
    "TrendResult",
    "long_term_covariance",
    "parameter_drift",
    "parameter_trend",
    "parameter_trends",
    "pattern_tests",
]

#: d₂ for moving ranges of two consecutive values: E[|x₁ − x₂|] = d₂ σ, d₂ = 2/√π.
D2 = 2.0 / np.sqrt(np.pi)


@dataclass(frozen=True)
class TrendResult:
    """Control chart of one parameter (customary unit, e.g. µm).

    Attributes
    ----------
    machine, parameter, unit : str
    run_ids : tuple of int
    dates : tuple of datetime
    values : ndarray (K,)
    centre, sigma, lower_limit, upper_limit : float
        x̄, σ̂ = MR̄/d₂ and x̄ ∓ 3σ̂ of the baseline runs.
    baseline : int
        How many of the first runs set the limits.
    out_of_control : ndarray of bool (K,)
        Outside [lower_limit, upper_limit].
    special_causes : dict of str to tuple of int
        The run ids where a test for a pattern fired (:func:`pattern_tests`): a shift
        (``run``) or a trend (``trend``). Either means drift more than a special cause: the
        document then carries a ``hint`` to ``mtm history drift``.
    """

    machine: str
    parameter: str
    unit: str
    run_ids: tuple[int, ...]
    dates: tuple[datetime, ...]
    values: np.ndarray
    centre: float
    sigma: float
    lower_limit: float
    upper_limit: float
    baseline: int
    out_of_control: np.ndarray
    special_causes: dict = field(default_factory=dict)

    def hint(self) -> dict | None:
        """What to run next when a pattern test fired: the drift model of the parameter."""
        fired = [name for name, runs in self.special_causes.items() if runs]
        if not fired:
            return None
        return {
            "reason": f"{' and '.join(PATTERNS[name] for name in fired)}: the parameter "
            "drifts; limits from a stable baseline do not describe it",
            "command": f"mtm history drift {self.parameter} --machine {self.machine}",
        }

    def to_dict(self) -> dict:
        """The JSON form (``kind: history-trend``, version 1); ``special_causes`` and
        ``hint`` (None when no pattern test fired) are additions that readers of version 1
        may ignore."""
        return {
            "kind": "history-trend",
            "version": 1,
            "machine": self.machine,
            "parameter": self.parameter,
            "unit": self.unit,
            "centre": self.centre,
            "sigma": self.sigma,
            "lower_limit": self.lower_limit,
            "upper_limit": self.upper_limit,
            "baseline": self.baseline,
            "method": "individuals chart, sigma = mean moving range / 1.128 (ISO 7870-2)",
            "special_causes": {k: list(v) for k, v in self.special_causes.items()},
            "hint": self.hint(),
            "runs": [
                {"id": i, "date": d.isoformat(), "value": float(v), "out_of_control": bool(o)}
                for i, d, v, o in zip(
                    self.run_ids, self.dates, self.values, self.out_of_control, strict=True
                )
            ],
        }

    @classmethod
    def from_dict(cls, doc: dict) -> TrendResult:
        """Inverse of :meth:`to_dict`."""
        runs = doc["runs"]
        return cls(
            machine=doc["machine"],
            parameter=doc["parameter"],
            unit=doc["unit"],
            run_ids=tuple(r["id"] for r in runs),
            dates=tuple(datetime.fromisoformat(r["date"]) for r in runs),
            values=np.array([r["value"] for r in runs], dtype=float),
            centre=doc["centre"],
            sigma=doc["sigma"],
            lower_limit=doc["lower_limit"],
            upper_limit=doc["upper_limit"],
            baseline=doc["baseline"],
            out_of_control=np.array([r["out_of_control"] for r in runs], dtype=bool),
            special_causes={k: tuple(v) for k, v in doc.get("special_causes", {}).items()},
        )


def control_limits(values: np.ndarray) -> tuple[float, float]:
    """Centre x̄ and σ̂ = MR̄/d₂ of an individuals chart (ISO 7870-2).

    Examples
    --------
    >>> centre, sigma = control_limits(np.array([1.0, 3.0, 2.0]))  # MR̄ = 1.5
    >>> centre, round(sigma, 6)
    (2.0, 1.32934)
    """
    if values.size < 2:
        raise InputError(f"a control chart needs at least 2 runs, got {values.size}")
    return float(values.mean()), float(np.abs(np.diff(values)).mean() / D2)


#: The pattern tests of an individuals chart (ISO 7870-2:2023, 8.4 and Annex B; the
#: Western Electric rules): their names and what they detect.
PATTERNS = {
    "run": "9 points in a row on one side of the centre line (a shift)",
    "trend": "6 points in a row steadily increasing or decreasing (a trend)",
}


def pattern_tests(values: np.ndarray, centre: float) -> dict[str, np.ndarray]:
    """Where the run and trend tests fire: the index of the last point of each window.

    ``run``: 9 consecutive points on the same side of the centre line (a point on it
    breaks the run); ``trend``: 6 consecutive points each above (or each below) the one
    before, i.e. 5 successive differences of one sign.

    Examples
    --------
    >>> tests = pattern_tests(np.arange(7.0), 3.0)
    >>> tests["trend"].tolist(), tests["run"].tolist()
    ([5, 6], [])
    """
    from numpy.lib.stride_tricks import sliding_window_view

    side = np.sign(values - centre)
    fired = {"run": np.empty(0, dtype=int), "trend": np.empty(0, dtype=int)}
    if values.size >= 9:
        windows = sliding_window_view(side, 9)
        same = np.abs(windows.sum(axis=1)) == 9
        fired["run"] = np.nonzero(same)[0] + 8
    if values.size >= 6:
        steps = sliding_window_view(np.sign(np.diff(values)), 5)
        fired["trend"] = np.nonzero(np.abs(steps.sum(axis=1)) == 5)[0] + 5
    return fired


def parameter_trend(
    engine: Engine,
    machine: str,
    parameter: str,
    *,
    since: datetime | None = None,
    baseline: int | None = None,
) -> TrendResult:
    """The Shewhart individuals chart of one parameter over a machine's calibrations.

    Parameters
    ----------
    engine : Engine
        The history (:func:`~mtmetrology.history.database.open_history`).
    machine, parameter : str
        Machine name and parameter name (``E_X0C``).
    since : datetime, optional
        Only runs performed since.
    baseline : int, optional
        The first ``baseline`` runs set the limits (phase I); default all.

    Returns
    -------
    TrendResult
        Limits x̄ ± 3 MR̄/d₂, the points outside them and the pattern tests that fired
        (:func:`pattern_tests`).
    """
    ids, dates, unit, values, _ = parameter_series(engine, machine, parameter, since=since)
    return _chart(machine, parameter, unit, ids, dates, values, baseline)


def parameter_trends(
    engine: Engine,
    machine: str,
    *,
    since: datetime | None = None,
    baseline: int | None = None,
) -> dict[str, TrendResult]:
    """The individuals chart of every parameter of a machine, from one read of its runs.

    The same charts as :func:`parameter_trend` parameter by parameter, read from each
    run's stored vector (:func:`~mtmetrology.history.series.parameter_matrix`: one row a
    run) instead of one query of K rows per parameter: for 10⁴ runs of the 84-coefficient
    model, one query instead of 84 (the web application's machine page; 7 s before).

    Returns
    -------
    dict
        :class:`TrendResult` by parameter name, in the runs' parameter order.
    """
    ids, dates, names, units, matrix = parameter_matrix(engine, machine, since=since)
    if not ids:
        raise InputError(f"machine {machine!r}: no calibration in the history to chart")
    return {
        name: _chart(machine, name, unit, ids, dates, matrix[:, j].copy(), baseline)
        for j, (name, unit) in enumerate(zip(names, units, strict=True))
    }


def _chart(machine, parameter, unit, ids, dates, values, baseline) -> TrendResult:
    """The chart of one series (values in ``unit``, oldest first): limits from the first
    ``baseline`` runs (all by default), the points outside them, the pattern tests."""
    n = len(values) if baseline is None else baseline
    if not 2 <= n <= len(values):
        raise InputError(f"--baseline {n}: must be between 2 and the {len(values)} runs")
    centre, sigma = control_limits(values[:n])
    lower, upper = centre - 3 * sigma, centre + 3 * sigma
    return TrendResult(
        machine,
        parameter,
        unit,
        tuple(ids),
        tuple(dates),
        values,
        centre,
        sigma,
        lower,
        upper,
        n,
        (values < lower) | (values > upper),
        {
            name: tuple(ids[i] for i in where)
            for name, where in pattern_tests(values, centre).items()
        },
    )


def long_term_covariance(
    engine: Engine,
    machine: str,
    *,
    since: datetime | None = None,
    values: str = "latest",
    add_within: bool = False,
) -> ParameterSet:
    """The long-term covariance of a machine's parameters over its recorded calibrations.

    The statistic of :func:`mtmetrology.identification.long_term.long_term_parameters`
    (Σ = 1/(K − 1) Σ_k (δ_k − δ̄)(δ_k − δ̄)ᵀ, plus the mean of the runs' own covariances
    with ``add_within``) on the runs since ``since``; the result is a parameter set
    ``mtm task uncertainty --long-term`` reads.

    Raises
    ------
    InputError
        Unknown machine, or fewer than two runs.
    """
    ids, dates, names, units, matrix = parameter_matrix(engine, machine, since=since)
    factors = np.array([parse_unit(u).factor for u in units])
    internal = matrix * factors  # (K, P) in mm, rad
    shared_names, shared_units = tuple(names), tuple(units)
    model = machine_model(engine, machine)
    within = run_covariances(engine, ids, names) if add_within else [None] * len(ids)
    sets = [
        ParameterSet(shared_names, row, shared_units, cov, machine=machine, model=model)
        for row, cov in zip(internal, within, strict=True)
    ]
    result = long_term_parameters(
        sets,
        values=values,
        add_within=add_within,
        sources=[f"run {i}" for i in ids] if len(ids) <= 50 else None,  # a short provenance
    )
    provenance = dict(result.provenance)
    provenance["history"] = {
        "runs": len(ids),
        "first": dates[0].isoformat(),
        "last": dates[-1].isoformat(),
        "since": None if since is None else since.isoformat(),
    }
    return ParameterSet(
        result.names,
        result.values,
        result.units,
        result.covariance,
        provenance,
        machine=machine,
        model=model,
    )


def parameter_drift(
    engine: Engine,
    machine: str,
    parameter: str,
    *,
    mpe: float | None = None,
    reliability: float = 0.95,
    since: datetime | None = None,
    prior: str = "reference",
    coverage_probability: float = DEFAULT_P,
) -> DriftResult:
    """The drift model of one parameter over a machine's calibrations and its due date
    (:func:`mtmetrology.history.drift.fit_drift`; each run's u is its measurement
    uncertainty; ``mpe`` in the parameter's customary unit; ``prior`` of the random-walk
    variance, which is marginalised; ``coverage_probability`` of the slope's interval,
    the policy's 2 Φ(2) − 1 by default, :mod:`mtmetrology.uncertainty.coverage`)."""
    _, dates, unit, values, u = parameter_series(engine, machine, parameter, since=since)
    return fit_drift(
        parameter,
        unit,
        dates,
        values,
        u,
        mpe=mpe,
        reliability=reliability,
        prior=prior,
        coverage_probability=coverage_probability,
    )
