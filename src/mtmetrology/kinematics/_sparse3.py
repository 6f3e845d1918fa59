"""3-vectors and 3×3 matrices stored by component, with structural zeros and ones.

The kinematic chain works on arrays of (trial, point) pairs.  Storing a vector as three
arrays and a matrix as nine (instead of ``(..., 3)`` and ``(..., 3, 3)`` blocks) keeps
every operation on contiguous memory, and marking structural zeros and ones (the
entries of a rotation about a coordinate axis, of a small-angle matrix, of the
identity) lets products skip them: ``A·R_z`` costs 12 multiply-adds instead of 45.
Entries are :data:`ZERO`, :data:`ONE`, Python floats or numpy arrays that broadcast.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "IDENTITY",
    "ONE",
    "ZERO",
    "add",
    "add_matrices",
    "add_vectors",
    "axis_rotation",
    "cross",
    "matmul",
    "matvec",
    "mul",
    "neg",
    "skew",
    "stack_matrix",
    "stack_vector",
]


class _Const:
    __slots__ = ("name",)

    def __init__(self, name: str):
        self.name = name

    def __repr__(self) -> str:
        return self.name


ZERO = _Const("ZERO")
ONE = _Const("ONE")
IDENTITY = ((ONE, ZERO, ZERO), (ZERO, ONE, ZERO), (ZERO, ZERO, ONE))


def mul(x, y):
    if x is ZERO or y is ZERO:
        return ZERO
    if x is ONE:
        return y
    if y is ONE:
        return x
    return x * y


def add(x, y):
    if x is ZERO:
        return y
    if y is ZERO:
        return x
    if x is ONE:
        x = 1.0
    if y is ONE:
        y = 1.0
    return x + y


def neg(x):
    if x is ZERO:
        return ZERO
    if x is ONE:
        return -1.0
    return -x


def add_vectors(u, v):
    return tuple(add(u[i], v[i]) for i in range(3))


def add_matrices(a, b):
    return tuple(tuple(add(a[i][j], b[i][j]) for j in range(3)) for i in range(3))


def _dot3(a0, a1, a2, b0, b1, b2):
    return add(add(mul(a0, b0), mul(a1, b1)), mul(a2, b2))


def matvec(a, v):
    """``a @ v`` for a sparse 3×3 ``a`` and 3-vector ``v``."""
    return tuple(_dot3(a[i][0], a[i][1], a[i][2], v[0], v[1], v[2]) for i in range(3))


def matmul(a, b):
    """``a @ b`` for sparse 3×3 matrices."""
    return tuple(
        tuple(_dot3(a[i][0], a[i][1], a[i][2], b[0][j], b[1][j], b[2][j]) for j in range(3))
        for i in range(3)
    )


def cross(e, v):
    """``e × v`` for 3-vectors with sparse entries."""
    return (
        add(mul(e[1], v[2]), neg(mul(e[2], v[1]))),
        add(mul(e[2], v[0]), neg(mul(e[0], v[2]))),
        add(mul(e[0], v[1]), neg(mul(e[1], v[0]))),
    )


def skew(e):
    """``[e]×`` so that ``skew(e) @ v = e × v``."""
    return (
        (ZERO, neg(e[2]), e[1]),
        (e[2], ZERO, neg(e[0])),
        (neg(e[1]), e[0], ZERO),
    )


def axis_rotation(direction: np.ndarray, angle):
    """Exact rotation matrix about a unit ``direction`` by ``angle`` (array).

    Coordinate directions (±X, ±Y, ±Z) give the sparse elementary rotation; any other
    direction the dense Rodrigues matrix ``cI + s[u]× + (1−c)uuᵀ``.
    """
    for k in range(3):
        if abs(abs(direction[k]) - 1.0) < 1e-15:
            a = angle if direction[k] > 0 else -angle
            c, s = np.cos(a), np.sin(a)
            i, j = (k + 1) % 3, (k + 2) % 3
            m = [[ZERO] * 3 for _ in range(3)]
            m[k][k] = ONE
            m[i][i], m[i][j] = c, -s
            m[j][i], m[j][j] = s, c
            return tuple(tuple(r) for r in m)
    c, s = np.cos(angle), np.sin(angle)
    u = direction
    ux = ((0.0, -u[2], u[1]), (u[2], 0.0, -u[0]), (-u[1], u[0], 0.0))
    return tuple(
        tuple(
            c * (1.0 if i == j else 0.0) + s * ux[i][j] + (1.0 - c) * u[i] * u[j] for j in range(3)
        )
        for i in range(3)
    )


def _dense(x, shape):
    if x is ZERO:
        return np.zeros(shape)
    if x is ONE:
        return np.ones(shape)
    return np.broadcast_to(x, shape)


def stack_vector(v, shape) -> np.ndarray:
    """A ``(*shape, 3)`` array from a sparse vector."""
    out = np.empty((*shape, 3))
    for i in range(3):
        out[..., i] = _dense(v[i], shape)
    return out


def stack_matrix(m, shape) -> np.ndarray:
    """A ``(*shape, 3, 3)`` array from a sparse matrix."""
    out = np.empty((*shape, 3, 3))
    for i in range(3):
        for j in range(3):
            out[..., i, j] = _dense(m[i][j], shape)
    return out
