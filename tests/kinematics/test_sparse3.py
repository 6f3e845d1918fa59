"""kinematics._sparse3 through its public functions, against dense numpy.

Random sparse vectors and matrices (entries ZERO, ONE, floats or arrays) are densified
and every operation is compared with the numpy product, cross product or Rodrigues
rotation matrix written here.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mtmetrology.kinematics import _sparse3 as s3

SHAPE = (4, 3)


def dense(x, shape=SHAPE) -> np.ndarray:
    if x is s3.ZERO:
        return np.zeros(shape)
    if x is s3.ONE:
        return np.ones(shape)
    return np.broadcast_to(np.asarray(x, dtype=float), shape)


def entry(rng: np.random.Generator):
    kind = rng.integers(4)
    if kind == 0:
        return s3.ZERO
    if kind == 1:
        return s3.ONE
    if kind == 2:
        return float(rng.normal())
    return rng.normal(size=SHAPE)


def vector(rng):
    return tuple(entry(rng) for _ in range(3))


def matrix(rng):
    return tuple(tuple(entry(rng) for _ in range(3)) for _ in range(3))


def dense_vector(v) -> np.ndarray:
    return np.stack([dense(x) for x in v], axis=-1)


def dense_matrix(m) -> np.ndarray:
    return np.stack([np.stack([dense(x) for x in row], axis=-1) for row in m], axis=-2)


SEEDS = st.integers(min_value=0, max_value=2**32 - 1)


@settings(max_examples=60, deadline=None)
@given(seed=SEEDS)
def test_scalar_operations_match_dense_arithmetic(seed):
    rng = np.random.default_rng(seed)
    x, y = entry(rng), entry(rng)
    np.testing.assert_allclose(dense(s3.mul(x, y)), dense(x) * dense(y), rtol=1e-15)
    np.testing.assert_allclose(dense(s3.add(x, y)), dense(x) + dense(y), rtol=1e-15)
    np.testing.assert_allclose(dense(s3.neg(x)), -dense(x), rtol=1e-15)


def test_structural_zeros_and_ones_are_kept_symbolic():
    a = np.arange(3.0)
    assert s3.mul(s3.ZERO, a) is s3.ZERO and s3.mul(a, s3.ZERO) is s3.ZERO
    assert s3.mul(s3.ONE, a) is a and s3.mul(a, s3.ONE) is a
    assert s3.add(s3.ZERO, a) is a and s3.add(a, s3.ZERO) is a
    assert s3.neg(s3.ZERO) is s3.ZERO
    assert s3.add(s3.ONE, s3.ONE) == 2.0 and s3.neg(s3.ONE) == -1.0
    assert repr(s3.ZERO) == "ZERO" and repr(s3.ONE) == "ONE"


@settings(max_examples=60, deadline=None)
@given(seed=SEEDS)
def test_vector_and_matrix_products_match_numpy(seed):
    rng = np.random.default_rng(seed)
    a, b, u, v = matrix(rng), matrix(rng), vector(rng), vector(rng)
    da, db, du, dv = dense_matrix(a), dense_matrix(b), dense_vector(u), dense_vector(v)
    np.testing.assert_allclose(
        dense_vector(s3.matvec(a, v)), np.einsum("...ij,...j->...i", da, dv), atol=1e-13
    )
    np.testing.assert_allclose(dense_matrix(s3.matmul(a, b)), da @ db, atol=1e-13)
    np.testing.assert_allclose(dense_vector(s3.cross(u, v)), np.cross(du, dv), atol=1e-13)
    np.testing.assert_allclose(dense_vector(s3.add_vectors(u, v)), du + dv, atol=1e-15)
    np.testing.assert_allclose(dense_matrix(s3.add_matrices(a, b)), da + db, atol=1e-15)
    # [u]x v = u x v
    np.testing.assert_allclose(dense_vector(s3.matvec(s3.skew(u), v)), np.cross(du, dv), atol=1e-13)
    assert s3.matmul(s3.IDENTITY, a) == a


def rodrigues(u: np.ndarray, angle: float) -> np.ndarray:
    u = np.asarray(u, dtype=float)
    k = np.array([[0, -u[2], u[1]], [u[2], 0, -u[0]], [-u[1], u[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


@pytest.mark.parametrize(
    "direction",
    [(1, 0, 0), (0, 1, 0), (0, 0, 1), (-1, 0, 0), (0, -1, 0), (0, 0, -1), (0.6, 0.0, 0.8)],
)
def test_axis_rotation_is_the_rodrigues_matrix(direction):
    angles = np.array([-2.5, -0.3, 0.0, 0.7, 3.0])
    d = np.asarray(direction, dtype=float)
    got = s3.stack_matrix(s3.axis_rotation(d, angles), angles.shape)
    for k, angle in enumerate(angles):
        np.testing.assert_allclose(got[k], rodrigues(d, angle), atol=1e-15)
    if np.count_nonzero(d) == 1:
        # a coordinate axis keeps four structural entries
        m = s3.axis_rotation(d, angles)
        flat = [x for row in m for x in row]
        assert sum(x is s3.ZERO for x in flat) == 4 and sum(x is s3.ONE for x in flat) == 1


def test_stack_vector_and_matrix_broadcast_and_copy():
    v = (s3.ZERO, s3.ONE, np.array([1.0, 2.0]))
    out = s3.stack_vector(v, (2,))
    np.testing.assert_array_equal(out, [[0.0, 1.0, 1.0], [0.0, 1.0, 2.0]])
    m = s3.stack_matrix(s3.IDENTITY, (2, 5))
    assert m.shape == (2, 5, 3, 3)
    np.testing.assert_array_equal(m, np.broadcast_to(np.eye(3), (2, 5, 3, 3)))
    m[0, 0, 0, 0] = 7.0  # a fresh array, not a view of a shared constant
    assert s3.stack_matrix(s3.IDENTITY, (1,))[0, 0, 0] == 1.0
