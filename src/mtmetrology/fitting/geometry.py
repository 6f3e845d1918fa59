"""Frames and sign conventions shared by the fits: centring, principal axes, orthonormal
bases completing an axis or a normal, and the sign of an undirected direction.

Every function here is a deterministic function of its input, so that a fit's evaluation
and its update (and a single fit and its batched counterpart) use the same frame.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "canonical",
    "canonical_rows",
    "centred",
    "centred_sets",
    "perpendicular_basis",
    "plane_basis",
    "point_set_size",
    "principal_axes",
    "singular_values",
]


def centred(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Points about their centroid, the centroid and the rms distance from it.

    Parameters
    ----------
    points : (n, d) ndarray, mm

    Returns
    -------
    x : (n, d) ndarray
        ``p_i − p̄``, mm.
    centroid : (d,) ndarray
        ``p̄ = Σ p_i / n``, mm.
    scale : float
        ``sqrt(Σ ‖x_i‖² / n)``, mm: the size the fits' tolerances are relative to.
    """
    centroid = points.mean(axis=0)
    x = points - centroid
    scale = float(np.sqrt(np.einsum("ij,ij->", x, x) / x.shape[0]))
    return x, centroid, scale


def centred_sets(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`centred` for K stacked point sets (K, n, d): x (K, n, d), centroids (K, d),
    scales (K,)."""
    centroid = points.mean(axis=1)  # (K, d)
    x = points - centroid[:, None, :]  # (K, n, d)
    scale = np.sqrt(np.mean(np.sum(x * x, axis=2), axis=1))  # (K,)
    return x, centroid, scale


def canonical(v: np.ndarray) -> np.ndarray:
    """Sign convention for undirected axes and normals: largest component positive.

    Parameters
    ----------
    v : (d,) ndarray

    Returns
    -------
    (d,) ndarray
        ``v`` or ``−v``, whichever has its largest-magnitude component positive.
    """
    return v if v[np.argmax(np.abs(v))] > 0 else -v


def canonical_rows(v: np.ndarray) -> np.ndarray:
    """:func:`canonical` applied to every row of ``v`` (K, d)."""
    k = np.argmax(np.abs(v), axis=1)
    sign = np.where(v[np.arange(len(v)), k] > 0, 1.0, -1.0)
    return v * sign[:, None]


def perpendicular_basis(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors ``e1, e2`` completing the unit vector ``a`` to a right-handed
    orthonormal frame ``(e1, e2, a)``.

    Parameters
    ----------
    a : (3,) ndarray
        Unit axis or normal.

    Returns
    -------
    e1, e2 : (3,) ndarray
        ``e1 = a × h / ‖a × h‖`` with ``h`` the coordinate axis of the smallest component
        of ``a``; ``e2 = a × e1``.
    """
    helper = np.eye(3)[int(np.argmin(np.abs(a)))]
    e1 = np.cross(a, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1)


def plane_basis(normal: np.ndarray) -> np.ndarray:
    """Rows ``u, v, n``: the frame of :func:`perpendicular_basis` as a (3, 3) matrix whose
    third row is the unit ``normal`` (local coordinates are ``basis @ p``)."""
    return np.stack([*perpendicular_basis(normal), normal])


def principal_axes(p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centroid, singular values and principal directions of a point set.

    Parameters
    ----------
    p : (n, d) ndarray, mm

    Returns
    -------
    centroid : (d,) ndarray, mm
    s : (min(n, d),) ndarray, mm
        Singular values of the centred points, decreasing.
    vt : (min(n, d), d) ndarray
        Principal directions (rows), in the order of ``s``.
    """
    centroid = p.mean(axis=0)
    _, s, vt = np.linalg.svd(p - centroid, full_matrices=False)
    return centroid, s, vt


def point_set_size(p: np.ndarray) -> float:
    """Radius of a point set (n, d) about its centroid, mm: the scale of its coordinates
    (``max_i ‖p_i − p̄‖``)."""
    return float(np.max(np.linalg.norm(p - p.mean(axis=0), axis=1)))


def singular_values(x: np.ndarray) -> np.ndarray:
    """Singular values of a matrix (or of centred points, one per row), decreasing: the
    spread of the points along their principal axes (× √n)."""
    return np.linalg.svd(x, compute_uv=False)
