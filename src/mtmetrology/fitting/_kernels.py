"""Compiled moment matrices of the batched circle/sphere fits (numba, cached where possible).

Imported only by the compiled backend of :mod:`mtmetrology.fitting.batch`.  One pass over
the points of each set forms the symmetric moment matrix ``A Aᵀ`` of
``A = [u; 1; ρ − r]`` (the normal equations ``JᵀJ``, ``Jᵀd`` and the cost ``Σd²`` of the
geometric fit in one matrix) in scalar accumulators, without the ``(k, d + 2, n)``
temporary of the numpy path.  Circles (d = 2) run the sphere loop with a zero third
coordinate, whose row and column are dropped.  The algebraic (Kåsa) start is formed the
same way.
"""

from __future__ import annotations

import numpy as np

from mtmetrology._backend import njit_cached


@njit_cached(nogil=True)
def round_moments(xt, index, centres, radii, out):  # pragma: no cover - compiled
    """out[s] = A Aᵀ for the set ``index[s]`` of ``xt`` (K, d, n), d = 2 or 3, about
    ``centres[s]``, ``radii[s]``."""
    d, n = xt.shape[1], xt.shape[2]
    m = np.empty((5, 5))
    keep = np.array([0, 1, 2, 3, 4]) if d == 3 else np.array([0, 1, 3, 4])
    for s in range(index.size):
        k = index[s]
        cx, cy = centres[s, 0], centres[s, 1]
        cz = centres[s, 2] if d == 3 else 0.0
        r = radii[s]
        s00 = s01 = s02 = s03 = s04 = s11 = s12 = s13 = s14 = 0.0
        s22 = s23 = s24 = s33 = s34 = s44 = 0.0
        for p in range(n):
            x = xt[k, 0, p] - cx
            y = xt[k, 1, p] - cy
            z = xt[k, 2, p] - cz if d == 3 else 0.0
            rho = np.sqrt(x * x + y * y + z * z)
            ux, uy, uz, e = x / rho, y / rho, z / rho, rho - r
            s00 += ux * ux
            s01 += ux * uy
            s02 += ux * uz
            s03 += ux
            s04 += ux * e
            s11 += uy * uy
            s12 += uy * uz
            s13 += uy
            s14 += uy * e
            s22 += uz * uz
            s23 += uz
            s24 += uz * e
            s33 += 1.0
            s34 += e
            s44 += e * e
        m[0, 0], m[0, 1], m[0, 2], m[0, 3], m[0, 4] = s00, s01, s02, s03, s04
        m[1, 1], m[1, 2], m[1, 3], m[1, 4] = s11, s12, s13, s14
        m[2, 2], m[2, 3], m[2, 4] = s22, s23, s24
        m[3, 3], m[3, 4], m[4, 4] = s33, s34, s44
        for i in range(keep.size):
            for j in range(i, keep.size):
                out[s, i, j] = out[s, j, i] = m[keep[i], keep[j]]


@njit_cached(nogil=True)
def kasa_moments(xt, scale, out):  # pragma: no cover - compiled
    """out[k] = D Dᵀ of the Kåsa design ``D = [2y; 1; ‖y‖²]`` (d + 2, n) of the centred
    set ``xt[k]`` (d, n), ``y = x / scale[k]``."""
    k_sets, d, n = xt.shape
    m = d + 2
    a = np.empty(m)
    for k in range(k_sets):
        f = 2.0 / scale[k]
        for i in range(m):
            for j in range(m):
                out[k, i, j] = 0.0
        for p in range(n):
            squared = 0.0
            for j in range(d):
                a[j] = xt[k, j, p] * f
                squared += a[j] * a[j]
            a[d] = 1.0
            a[d + 1] = 0.25 * squared
            for i in range(m):
                for j in range(i + 1):
                    out[k, i, j] += a[i] * a[j]
        for i in range(m):
            for j in range(i):
                out[k, j, i] = out[k, i, j]


@njit_cached(nogil=True)
def round_residuals(xt, centres, radii, out):  # pragma: no cover - compiled
    """out[k, p] = ‖x_kp − c_k‖ − r_k of coordinate-major sets ``xt`` (K, d, n), in one
    pass (the numpy path forms the (K, d, n) differences first)."""
    k_sets, d, n = xt.shape
    for k in range(k_sets):
        for p in range(n):
            squared = 0.0
            for j in range(d):
                e = xt[k, j, p] - centres[k, j]
                squared += e * e
            out[k, p] = np.sqrt(squared) - radii[k]
