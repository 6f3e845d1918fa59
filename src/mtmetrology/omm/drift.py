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
from mtmetrology.optimize import least_squares

__all__ = ["CUBIC_COEFFICIENTS", "MIN_CUBIC_POINTS", "detrend_cubic", "sliding_window_std"]

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
    deviation of the residuals specifies the probing repeatability. The fit is linear
    least squares by the library's Gauss–Newton core (one step); the abscissa is mapped
    to [−1, 1] so that the Vandermonde columns stay of order one.

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
    n, k = y2.shape
    if n < MIN_CUBIC_POINTS:
        raise InputError(
            f"{where}: {n} values; cubic drift removal needs at least {MIN_CUBIC_POINTS} "
            f"(4 coefficients and 2 degrees of freedom left); record more replicates"
        )
    t = np.arange(n, dtype=float) if abscissa is None else np.asarray(abscissa, dtype=float)
    if t.shape != (n,) or not (np.all(np.isfinite(t)) and np.all(np.isfinite(y2))):
        raise InputError(f"{where}: values and abscissa must be finite, with {n} abscissae")
    if np.unique(t).size < CUBIC_COEFFICIENTS:
        raise InputError(f"{where}: fewer than 4 distinct times; a cubic drift cannot be fitted")
    z = 2.0 * (t - t.min()) / (t.max() - t.min()) - 1.0
    vander = np.vander(z, CUBIC_COEFFICIENTS, increasing=True)
    residuals = np.empty_like(y2)
    for j in range(k):  # k is small (the coordinates of one target)
        res = least_squares(
            lambda c, col=y2[:, j]: (vander @ c - col, vander),
            np.zeros(CUBIC_COEFFICIENTS),
            require_full_rank=True,
        )
        if not res.success:  # full rank is checked above: a failure here is numerical
            raise ConvergenceError(f"{where}: cubic drift fit failed ({res.message})")
        residuals[:, j] = y2[:, j] - vander @ res.x
    return residuals[:, 0] if single else residuals


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
