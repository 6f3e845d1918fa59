"""The symmetry of a covariance matrix read from a file: one rule for every reader.

A covariance written by a program is symmetric only to the rounding of the arithmetic that
made it (``J⁺ V J⁺ᵀ`` evaluated in floating point, a unit conversion, a decimal print):
its mirrored entries may differ by a few ulps of the matrix's *largest* entry, which on a
small off-diagonal entry is a large relative difference. An elementwise relative test
(``rtol=1e-9, atol=0``) therefore refuses such a file by chance (a tracker calibration
asymmetric by 3e-16 on entries near 1e-7, issue 30). The rule here is relative to the
matrix's scale::

    max |C − Cᵀ| ≤ 1e-9 · max |C|      → accepted, returned as (C + Cᵀ)/2 (exactly symmetric)
    otherwise                           → refused, naming the file and the field

A matrix that passes is symmetrised, so every computation downstream (Cholesky, eigvalsh,
u = sqrt(diag C)) sees one matrix, and writers that write what they read write it exactly
symmetric. ``(C + Cᵀ)/2`` is exactly symmetric in IEEE arithmetic: a + b = b + a and the
halving is exact.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.io.files import InputFileError

__all__ = ["SYMMETRY_TOLERANCE", "symmetric", "symmetric_covariance"]

#: Largest accepted max|C − Cᵀ| relative to max|C|.
SYMMETRY_TOLERANCE = 1e-9


def symmetric(matrix) -> np.ndarray:
    """(C + Cᵀ)/2 over the last two axes: the exactly symmetric matrix a writer writes."""
    c = np.asarray(matrix, dtype=float)
    return 0.5 * (c + np.swapaxes(c, -1, -2))


def symmetric_covariance(matrix, where: str) -> np.ndarray:
    """A covariance read from a file, checked for symmetry and symmetrised.

    Parameters
    ----------
    matrix : array_like, shape (..., n, n)
        The matrix as read (finite numbers; a stack is checked matrix by matrix).
    where : str
        The file and field, e.g. ``"result.json: covariance.matrix"``, for the message.

    Returns
    -------
    ndarray, shape (..., n, n)
        ``(C + Cᵀ)/2``, exactly symmetric.

    Raises
    ------
    InputFileError
        ``max |C − Cᵀ| > 1e-9 · max |C|`` (per matrix of a stack), naming ``where``, the
        largest asymmetry and the scale; a matrix that is not square.
    """
    c = np.asarray(matrix, dtype=float)
    if c.ndim < 2 or c.shape[-1] != c.shape[-2]:
        raise InputFileError(f"{where}: a covariance must be a square matrix, got {c.shape}")
    asymmetry = np.abs(c - np.swapaxes(c, -1, -2)).max(axis=(-1, -2), initial=0.0)
    scale = np.abs(c).max(axis=(-1, -2), initial=0.0)
    bad = asymmetry > SYMMETRY_TOLERANCE * scale
    if np.any(bad):
        worst = int(np.argmax(np.where(bad, asymmetry / np.where(scale > 0, scale, 1.0), -1.0)))
        a, s = np.ravel(asymmetry)[worst], np.ravel(scale)[worst]
        raise InputFileError(
            f"{where}: covariance matrix is not symmetric (max |C − Cᵀ| = {a:.3g}, "
            f"above {SYMMETRY_TOLERANCE:g} × max |C| = {SYMMETRY_TOLERANCE * s:.3g})"
        )
    return symmetric(c)
