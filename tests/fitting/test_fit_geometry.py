"""Tests of mtmetrology.fitting.geometry: the frames and sign conventions the fits share."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.fitting.geometry import (
    canonical,
    canonical_rows,
    centred,
    centred_sets,
    perpendicular_basis,
    plane_basis,
    point_set_size,
    principal_axes,
    singular_values,
)


@pytest.mark.parametrize("seed", range(5))
def test_plane_basis_is_a_right_handed_orthonormal_frame_on_the_normal(seed):
    a = np.random.default_rng(seed).standard_normal(3)
    a /= np.linalg.norm(a)
    basis = plane_basis(a)
    np.testing.assert_allclose(basis @ basis.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(basis) == pytest.approx(1.0, abs=1e-14)
    np.testing.assert_array_equal(basis[2], a)
    e1, e2 = perpendicular_basis(a)
    np.testing.assert_array_equal(basis[:2], [e1, e2])


def test_perpendicular_basis_of_a_coordinate_axis_is_closed_form():
    """a = z: the helper is x (a smallest component, the first), e1 = z × x = y and
    e2 = z × y = −x."""
    e1, e2 = perpendicular_basis(np.array([0.0, 0.0, 1.0]))
    np.testing.assert_array_equal(e1, [0.0, 1.0, 0.0])
    np.testing.assert_array_equal(e2, [-1.0, 0.0, 0.0])


def test_canonical_makes_the_largest_component_positive():
    np.testing.assert_array_equal(canonical(np.array([0.1, -0.9, 0.3])), [-0.1, 0.9, -0.3])
    np.testing.assert_array_equal(canonical(np.array([0.1, 0.9, -0.3])), [0.1, 0.9, -0.3])
    rows = np.random.default_rng(1).standard_normal((20, 3))
    np.testing.assert_array_equal(canonical_rows(rows), [canonical(r) for r in rows])


def test_centring_single_and_stacked_sets_agree_with_the_definitions():
    sets = np.random.default_rng(2).normal(5.0, 2.0, (4, 30, 3))
    x, centroid, scale = centred_sets(sets)
    for k, p in enumerate(sets):
        xk, ck, sk = centred(p)
        np.testing.assert_allclose(ck, p.mean(axis=0), rtol=1e-15)
        assert sk == pytest.approx(np.sqrt(np.mean(np.sum((p - ck) ** 2, axis=1))), rel=1e-14)
        np.testing.assert_allclose(x[k], xk, atol=1e-14)
        np.testing.assert_allclose(centroid[k], ck, rtol=1e-15)
        assert scale[k] == pytest.approx(sk, rel=1e-14)


def test_principal_axes_and_size_of_a_rectangle_of_points():
    """Corners of a 6 × 2 rectangle at (10, 20, 30), rotated: singular values √4·(3, 1, 0)
    along the rotated x and y; the size is the half-diagonal √10."""
    corners = np.array([[3, 1, 0], [-3, 1, 0], [-3, -1, 0], [3, -1, 0]], dtype=float)
    c, s_ = np.cos(0.4), np.sin(0.4)
    rot = np.array([[c, -s_, 0.0], [s_, c, 0.0], [0.0, 0.0, 1.0]])
    p = corners @ rot.T + [10.0, 20.0, 30.0]
    centroid, s, vt = principal_axes(p)
    np.testing.assert_allclose(centroid, [10.0, 20.0, 30.0], atol=1e-13)
    np.testing.assert_allclose(s, [6.0, 2.0, 0.0], atol=1e-13)
    np.testing.assert_allclose(np.abs(vt[0]), np.abs(rot[:, 0]), atol=1e-13)
    np.testing.assert_allclose(singular_values(p - centroid), s, atol=1e-13)
    assert point_set_size(p) == pytest.approx(np.sqrt(10.0), rel=1e-14)
