"""The repeatability u_p of a budget and the minimum of repeats ISO 15530-3 requires.

u_p (Mutilba et al., Eq. 3) is the sample standard deviation (n − 1) of repeated cycles,
or, as ISO 15530-3 is used in practice, the largest over several series; the standard asks
for at least 20 repeats in series of at least 10 cycles (ISO 15530-3, clause 7).
:mod:`mtmetrology.budgets.iso15530` enforces the minimum for the standard's policies and
records an allowed shortfall; :mod:`mtmetrology.budgets.volumetric_map` takes u_p from here.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.budgets.choices import RepeatabilityMethod
from mtmetrology.errors import InputError

__all__ = ["MIN_CYCLES_PER_SERIES", "MIN_REPEATS", "repeat_shortfall", "repeatability"]

#: ISO 15530-3 usage of the repeatability: cycles per series and repeats in all.
MIN_CYCLES_PER_SERIES = 10
MIN_REPEATS = 20


def repeat_shortfall(n: int, series: np.ndarray | None = None) -> list[str]:
    """How repeats fall short of ISO 15530-3's minimum (empty when they meet it).

    Parameters
    ----------
    n : int
        Repeats in all.
    series : (n,) array, optional
        Series label of each repeat; one series without it.

    Returns
    -------
    list of str
        One sentence per shortfall: fewer than 20 repeats in all, a series of fewer than
        10 cycles.
    """
    out = []
    if n < MIN_REPEATS:
        out.append(f"{n} repeats, ISO 15530-3 requires at least {MIN_REPEATS}")
    labels = np.asarray([] if series is None else series)
    for label in np.unique(labels):  # one series (no labels): the count above says it all
        cycles = int(np.count_nonzero(labels == label))
        if cycles < MIN_CYCLES_PER_SERIES:
            out.append(
                f"series {str(label)!r} has {cycles} cycles, ISO 15530-3 requires at least "
                f"{MIN_CYCLES_PER_SERIES} per series"
            )
    return out


def repeatability(
    values: np.ndarray,
    series: np.ndarray | None = None,
    method: RepeatabilityMethod | str = RepeatabilityMethod.SAMPLE,
    *,
    allow_few_repeats: bool = False,
) -> float:
    """u_p from repeated measurement cycles (Mutilba et al., Eq. 3).

    Parameters
    ----------
    values : (n,) array
        One result per cycle.
    series : (n,) array, optional
        Series label of each value (a day, a re-clamping ...); one series without it.
    method : RepeatabilityMethod
        ``sample``: u_p = √(Σ(y_i − ȳ)² / (n − 1)) over all values (n ≥ 2).
        ``max-over-series``: the largest such standard deviation over the series, each of
        at least 10 cycles, at least 20 repeats in all (ISO 15530-3 usage).
    allow_few_repeats : bool
        ``max-over-series`` with fewer repeats than the standard's minimum (each series
        still needs 2); the caller records the deviation (:func:`repeat_shortfall`).

    Returns
    -------
    float
        u_p, in the unit of ``values``.

    Raises
    ------
    InputError
        Too few values for the method.
    """
    y = np.asarray(values, dtype=float).ravel()
    method = RepeatabilityMethod(method)
    if method is RepeatabilityMethod.SAMPLE:
        if y.size < 2:
            raise InputError(f"u_p: {y.size} repeated value(s), at least 2 needed")
        return float(np.std(y, ddof=1))
    labels = np.zeros(y.size, dtype=int) if series is None else np.asarray(series)
    shortfall = repeat_shortfall(y.size, series)
    if shortfall and not allow_few_repeats:
        raise InputError(f"u_p (max-over-series): {'; '.join(shortfall)}")
    worst = 0.0
    for label in np.unique(labels):
        s = y[labels == label]
        if s.size < 2:
            raise InputError(f"u_p (max-over-series): series {str(label)!r} has 1 cycle")
        worst = max(worst, float(np.std(s, ddof=1)))
    return worst
