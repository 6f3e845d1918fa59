"""Validation of point sets at the door of every fit (least squares and minimum zone).

One check of shape, finiteness and count (:func:`check_points`) and one of spread
(:func:`require_spread`) so that a degenerate point set is refused with the same
one-line message whichever criterion was asked for.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.errors import InputError

__all__ = ["DEGENERATE", "FitError", "check_points", "require_spread"]

# A singular value below this fraction of the largest marks a degenerate point set.
DEGENERATE = 1e-10


class FitError(InputError):
    """A point set from which the requested element cannot be fitted."""


def check_points(points: object, kind: str, dims: tuple[int, ...], min_points: int) -> np.ndarray:
    """Validate a point array at the public boundary; return a float ``(n, d)`` copy.

    Parameters
    ----------
    points : array_like
        The measured points, one per row.
    kind : str
        What is fitted (``"circle"``, ``"roundness"``, ...); leads the error message.
    dims : tuple of int
        Accepted numbers of coordinates per point.
    min_points : int
        Fewest points that determine the element.

    Returns
    -------
    numpy.ndarray
        The points as a new float array of shape ``(n, d)``.

    Raises
    ------
    FitError
        On a non-numeric array, a wrong shape, a NaN or inf coordinate (naming the first
        such point) or fewer than ``min_points`` points.
    """
    try:
        arr = np.array(points, dtype=float)
    except (TypeError, ValueError) as exc:
        raise FitError(f"{kind}: points must be a numeric (n, d) array ({exc})") from exc
    if arr.ndim != 2 or arr.shape[1] not in dims:
        want = " or ".join(f"(n, {d})" for d in dims)
        raise FitError(f"{kind}: points must have shape {want}, got {arr.shape}")
    bad = ~np.all(np.isfinite(arr), axis=1)
    if bad.any():
        rows = np.flatnonzero(bad)
        raise FitError(
            f"{kind}: point {int(rows[0])} is not finite (NaN or inf; {rows.size} such point(s))"
        )
    if arr.shape[0] < min_points:
        raise FitError(
            f"{kind}: {arr.shape[0]} points are fewer than the {min_points} needed "
            f"to determine the element"
        )
    return arr


def require_spread(
    kind: str, singular_values: np.ndarray, n_points: int, rank: int, what: str, hint: str = ""
) -> None:
    """Raise unless the centred points span at least ``rank`` dimensions.

    The set is degenerate when :math:`s_{rank} \\le 10^{-10}\\, s_1`, with
    :math:`s_1 \\ge s_2 \\ge \\dots` the singular values of the centred coordinates.

    Parameters
    ----------
    kind : str
        What is fitted; leads the error message.
    singular_values : numpy.ndarray
        Singular values of the centred points, in decreasing order.
    n_points : int
        Number of points, for the message.
    rank : int
        Dimensions the points must span (1: not coincident, 2: not collinear,
        3: not coplanar).
    what : str
        The degeneracy in words (``"collinear"``, ``"coplanar"``, ...).
    hint : str, optional
        Appended to the message (e.g. ``"; a cone needs points off one plane"``).

    Raises
    ------
    FitError
        When the points are degenerate, giving the relative singular value.
    """
    s = singular_values
    if s[0] == 0.0 or s[rank - 1] <= DEGENERATE * s[0]:
        rel = 0.0 if s[0] == 0.0 else s[rank - 1] / s[0]
        raise FitError(
            f"{kind}: the {n_points} points are {what} (relative singular value "
            f"{rel:.1e} of the centred points){hint}"
        )
