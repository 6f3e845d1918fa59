"""Validation of point sets at the door of every fit (least squares and minimum zone).

One check of shape, finiteness and count (:func:`check_points`, stacked:
:func:`check_point_sets`) and one of spread (:func:`require_spread`, stacked:
:func:`require_spread_sets`, :func:`require_spread_scatter`) so that a degenerate point
set is refused with the same one-line message whichever criterion was asked for.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.errors import InputError

__all__ = [
    "DEGENERATE",
    "FitError",
    "check_normal",
    "check_point_sets",
    "check_points",
    "require_spread",
    "require_spread_scatter",
    "require_spread_sets",
]

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


def check_normal(normal: object) -> np.ndarray:
    """Validate a plane normal or axis direction given by the caller; return it unit.

    Parameters
    ----------
    normal : array_like, (3,)

    Returns
    -------
    (3,) ndarray
        ``normal / ‖normal‖``.

    Raises
    ------
    FitError
        Unless ``normal`` is a finite, non-zero 3-vector.
    """
    n = np.asarray(normal, dtype=float)
    if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) == 0.0:
        raise FitError(f"normal must be a finite, non-zero 3-vector, got {normal!r}")
    return n / np.linalg.norm(n)


def check_point_sets(
    points: object, kind: str, dims: tuple[int, ...], min_points: int
) -> np.ndarray:
    """:func:`check_points` for K stacked point sets (K, n, d) of a batched fit.

    Parameters
    ----------
    points : array_like, (K, n, d)
    kind, dims, min_points
        As for :func:`check_points`.

    Returns
    -------
    numpy.ndarray
        The points as a float (K, n, d) array (not copied when already one: no fit writes
        into it).

    Raises
    ------
    FitError
        On a non-numeric array, a wrong shape, no sets, fewer than ``min_points`` points per
        set, or a set with a NaN or inf coordinate (naming the first such set).
    """
    try:
        arr = np.asarray(points, dtype=float)
    except (TypeError, ValueError) as exc:
        raise FitError(f"{kind}: points must be a numeric (K, n, d) array ({exc})") from exc
    if arr.ndim != 3 or arr.shape[2] not in dims:
        want = " or ".join(f"(K, n, {d})" for d in dims)
        raise FitError(f"{kind}: points must have shape {want}, got {arr.shape}")
    if arr.shape[0] == 0:
        raise FitError(f"{kind}: no point sets (K = 0)")
    if arr.shape[1] < min_points:
        raise FitError(
            f"{kind}: {arr.shape[1]} points per set are fewer than the {min_points} needed"
        )
    bad = ~np.all(np.isfinite(arr), axis=(1, 2))
    if bad.any():
        raise FitError(
            f"{kind}: {int(bad.sum())} set(s) contain NaN or inf (first: set {int(np.argmax(bad))})"
        )
    return arr


def require_spread_sets(kind: str, x: np.ndarray, rank: int, what: str) -> np.ndarray:
    """:func:`require_spread` for K stacked centred point sets x (K, n, d): raise naming
    the first set whose points span fewer than ``rank`` dimensions (same threshold,
    :data:`DEGENERATE`).

    Returns
    -------
    (K, d, d) ndarray
        The stacked right singular vectors of the sets, for reuse.
    """
    _, s, vt = np.linalg.svd(x, full_matrices=False)
    rel = s[:, rank - 1] / np.maximum(s[:, 0], 1e-300)
    bad = (s[:, 0] == 0) | (rel <= DEGENERATE)
    if bad.any():
        k = int(np.argmax(bad))
        raise FitError(
            f"{kind}: {int(bad.sum())} set(s) are {what}; first: set {k} "
            f"(relative singular value {rel[k]:.1e} of its centred points)"
        )
    return vt


def require_spread_scatter(kind: str, scatter: np.ndarray, first_index: int) -> None:
    """Coplanarity check of centred 3-D sets from their 3×3 scatter matrices (k, 3, 3).

    With eigenvalues λ1 ≤ λ2 ≤ λ3, ``det / m2`` (m2 the sum of the principal 2×2 minors)
    lies in [λ1/3, λ1], so ``det ≤ 1e-14 · m2 · trace`` flags sets whose smallest
    singular value is below ~1e-7 of the largest (exactly coplanar sets sit at the
    rounding level ~1e-16); closed-form and much cheaper than stacked eigenvalues.
    ``first_index`` is the index of the first set in the whole batch, for the message.
    """
    a, b, c = scatter[:, 0, 0], scatter[:, 1, 1], scatter[:, 2, 2]
    d, e, f = scatter[:, 0, 1], scatter[:, 0, 2], scatter[:, 1, 2]
    det = a * (b * c - f * f) - d * (d * c - f * e) + e * (d * f - b * e)
    m2 = a * b - d * d + a * c - e * e + b * c - f * f
    bad = det <= 1e-14 * m2 * (a + b + c)
    if bad.any():
        k = int(np.argmax(bad))
        lam = np.linalg.eigvalsh(scatter[k])
        rel = np.sqrt(max(lam[0], 0.0) / max(lam[2], 1e-300))
        raise FitError(
            f"{kind}: {int(bad.sum())} set(s) are coplanar; first: set {first_index + k} "
            f"(relative singular value {rel:.1e} of its centred points)"
        )
