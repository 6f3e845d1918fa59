"""Drift removal and sliding-window repeatability of replicated probing series.

Repeatability should describe the random scatter of the measuring system only. In long
replicate series (the "ordered" and "shuffled" ring-gauge tests of Sepahi Boroujeni
(2021), §4) the readings also drift, mainly thermally; the thesis fits a cubic polynomial
to each series and takes the standard deviation of the fit residuals as repeatability
(:func:`detrend_cubic`). Once the drift has settled, the stability of the repeatability
over time is shown by the standard deviation inside a window of w iterations sliding
along the series (w = 10 over iterations 26–50 in the thesis; :func:`sliding_window_std`).

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, §4 (Figs. 4-19, 4-20 and A.2).
"""

from __future__ import annotations

import numpy as np

from mtmetrology.errors import ConvergenceError, InputError
from mtmetrology.optimize import least_squares_batch

__all__ = [
    "CUBIC_COEFFICIENTS",
    "MIN_CUBIC_POINTS",
    "detrend_cubic",
    "detrend_cubic_stack",
    "sliding_window_std",
]

#: Coefficients of the drift polynomial (degree 3): the residuals keep n − 4 degrees of freedom.
CUBIC_COEFFICIENTS = 4
#: Fewest points of a series for drift removal: 4 coefficients plus 2 degrees of freedom
#: for the residual standard deviation.
MIN_CUBIC_POINTS = CUBIC_COEFFICIENTS + 2


def detrend_cubic(values, abscissa=None, *, where: str = "series") -> np.ndarray:
    """Residuals of a least-squares cubic drift fitted to a replicate series.

    Parameters
    ----------
    values : (n,) or (n, k) array_like
        The series (e.g. readings in mm), in time order; k series sharing one abscissa
        are fitted separately.
    abscissa : (n,) array_like, optional
        Time (or any monotone measure of it) of each value; the iteration index
        0, 1, …, n − 1 by default. The residuals do not depend on the unit or origin of
        the abscissa (a cubic stays a cubic under an affine change of it).
    where : str
        Name of the series for error messages.

    Returns
    -------
    ndarray, shape of ``values``
        values − (c0 + c1 z + c2 z² + c3 z³), z the abscissa mapped to [−1, 1]. The
        residuals sum to zero; the repeatability is their standard deviation with
        n − 4 degrees of freedom, s = √(Σ r² / (n − 4)).

    Raises
    ------
    InputError
        Fewer than :data:`MIN_CUBIC_POINTS` values, fewer than 4 distinct abscissae,
        non-finite values or shapes that do not match.

    Notes
    -----
    Sepahi Boroujeni (2021), §4: cubic polynomials are fitted to the recorded
    coordinates and radial projections to remove the (thermal) drift, and the standard
    deviation of the residuals specifies the probing repeatability. See
    :func:`detrend_cubic_stack` for the computation.

    References
    ----------
    Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with
    On-Machine Tool Metrology*. PhD thesis, Polytechnique Montréal, §4 and App. A.

    Examples
    --------
    An exact cubic leaves no residual:

    >>> t = np.arange(8.0)
    >>> bool(np.all(np.abs(detrend_cubic(0.5 - 0.2 * t + 0.03 * t**3)) < 1e-12))
    True
    """
    y = np.asarray(values, dtype=float)
    single = y.ndim == 1
    y2 = y[:, None] if single else y
    if y2.ndim != 2:
        raise InputError(f"{where}: values must be (n,) or (n, k), got shape {y.shape}")
    n = y2.shape[0]
    t = np.arange(n, dtype=float) if abscissa is None else np.asarray(abscissa, dtype=float)
    if t.shape != (n,):
        raise InputError(f"{where}: {n} values but abscissa of shape {t.shape}")
    residuals = detrend_cubic_stack(y2[None], t[None], where=where)[0]
    return residuals[:, 0] if single else residuals


def detrend_cubic_stack(values, abscissa, *, where: str = "series") -> np.ndarray:
    """:func:`detrend_cubic` for K series of equal length at once.

    Parameters
    ----------
    values : (K, n, k) array_like
        K groups of k series of n values (e.g. the X, Y, Z, N, T readings of K targets).
    abscissa : (K, n) array_like
        Time of each value of each group.
    where : str
        Name of the source for error messages.

    Returns
    -------
    (K, n, k) ndarray
        Residuals of the cubic fitted to each series.

    Raises
    ------
    InputError
        n < :data:`MIN_CUBIC_POINTS`, a group with fewer than 4 distinct times (the
        message gives its position), non-finite values or mismatched shapes.

    Notes
    -----
    Each series is the linear least-squares problem min ‖V c − y‖, V = [1, z, z², z³]
    with z the group's times mapped to [−1, 1] (Vandermonde columns of order one), and
    y centred on its mean (the constant is in the model, so the residuals do not change,
    and the fit works on the µm-size scatter instead of the mm-size readings). All K·k
    problems go to the library's batched Gauss–Newton core at once, which solves a
    linear problem in its first step.

    Examples
    --------
    >>> t = np.tile(np.arange(6.0), (2, 1))
    >>> y = np.stack([t[0] ** 3, 1.0 - t[1]])[..., None]
    >>> bool(np.abs(detrend_cubic_stack(y, t)).max() < 1e-12)
    True
    """
    y = np.asarray(values, dtype=float)
    t = np.asarray(abscissa, dtype=float)
    if y.ndim != 3 or t.shape != y.shape[:2]:
        raise InputError(f"{where}: values (K, n, k) and abscissa (K, n) do not match")
    n_groups, n, k = y.shape
    if n < MIN_CUBIC_POINTS:
        raise InputError(
            f"{where}: {n} values; cubic drift removal needs at least {MIN_CUBIC_POINTS} "
            f"(4 coefficients and 2 degrees of freedom left); record more replicates"
        )
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(y))):
        raise InputError(f"{where}: values and abscissa must be finite")
    distinct = 1 + np.sum(np.diff(np.sort(t, axis=1), axis=1) > 0, axis=1)
    if np.any(distinct < CUBIC_COEFFICIENTS):
        g = int(np.flatnonzero(distinct < CUBIC_COEFFICIENTS)[0])
        at = f" (series {g + 1})" if n_groups > 1 else ""
        raise InputError(f"{where}{at}: fewer than 4 distinct times; a cubic cannot be fitted")
    low, high = t.min(axis=1, keepdims=True), t.max(axis=1, keepdims=True)
    z = 2.0 * (t - low) / (high - low) - 1.0
    vander = z[..., None] ** np.arange(CUBIC_COEFFICIENTS)  # (K, n, 4)
    centred = y - y.mean(axis=1, keepdims=True)
    # One problem per (group, series): normal matrix VᵀV of its group, right side Vᵀy.
    gram = np.repeat(np.einsum("gni,gnj->gij", vander, vander), k, axis=0)
    rhs = np.einsum("gni,gnk->gki", vander, centred).reshape(-1, CUBIC_COEFFICIENTS)
    yy = np.einsum("gnk,gnk->gk", centred, centred).ravel()

    def normal_equations(c, index):
        a = gram[index]
        ac = np.einsum("kij,kj->ki", a, c)
        rr = yy[index] - 2.0 * np.einsum("ki,ki->k", c, rhs[index]) + np.einsum("ki,ki->k", c, ac)
        return a, ac - rhs[index], np.maximum(rr, 0.0), n

    scale = np.sqrt(yy) + np.finfo(float).tiny
    solve = least_squares_batch(
        normal_equations, np.zeros((n_groups * k, CUBIC_COEFFICIENTS)), xtol=1e-12 * scale
    )
    if not np.all(solve.success):  # full rank is checked above: a failure is numerical
        raise ConvergenceError(f"{where}: cubic drift fit failed ({solve.message})")
    coefficients = solve.x.reshape(n_groups, k, CUBIC_COEFFICIENTS)
    return centred - np.einsum("gni,gki->gnk", vander, coefficients)


def sliding_window_std(values, window: int, *, start: int = 0, where: str = "series"):
    """Sample standard deviation inside a window of ``window`` points sliding one by one.

    Parameters
    ----------
    values : (n,) or (n, k) array_like
        The series in time order (k coordinates side by side).
    window : int
        Points per window, w ≥ 2 (Sepahi Boroujeni (2021) uses 10).
    start : int, default 0
        Index of the first point of the first window (0-based).
    where : str
        Name of the series for error messages.

    Returns
    -------
    starts : (n_w,) ndarray of int
        Index of the first point of each window: start, start + 1, …, n − w.
    std : (n_w,) or (n_w, k) ndarray
        Standard deviation (ddof = 1) of the values in each window, in the unit of
        ``values``.

    Raises
    ------
    InputError
        ``window`` < 2, ``start`` < 0, or a window that does not fit in the series.

    Notes
    -----
    Sepahi Boroujeni (2021), §4 (Fig. 4-20): the standard deviation within a
    10-iteration frame slid between iterations 26 and 50 shows how stable the
    repeatability is over the time span of a measurement.

    Examples
    --------
    >>> starts, s = sliding_window_std([0.0, 1.0, 0.0, 1.0, 5.0], 3)
    >>> starts.tolist(), s.round(3).tolist()
    ([0, 1, 2], [0.577, 0.577, 2.646])
    """
    y = np.asarray(values, dtype=float)
    if y.ndim not in (1, 2):
        raise InputError(f"{where}: values must be (n,) or (n, k), got shape {y.shape}")
    if int(window) != window or window < 2:
        raise InputError(f"window: must be an integer >= 2, got {window}")
    if int(start) != start or start < 0:
        raise InputError(f"window start: must be an integer >= 0, got {start}")
    n = y.shape[0]
    if start + window > n:
        raise InputError(
            f"{where}: a window of {window} starting at point {start + 1} needs "
            f"{start + window} points, the series has {n}; use a smaller window or start"
        )
    frames = np.lib.stride_tricks.sliding_window_view(y[start:], window, axis=0)
    return np.arange(start, n - window + 1), frames.std(axis=-1, ddof=1)
