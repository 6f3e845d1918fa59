"""Tests of mtmetrology.fitting.batch: batched fits equal the one-at-a-time fits."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mtmetrology.fitting.batch import fit_circles, fit_lines, fit_planes, fit_spheres
from mtmetrology.fitting.least_squares import (
    FitError,
    fit_circle,
    fit_line,
    fit_plane,
    fit_sphere,
)

AGREE = 1e-10  # mm and rad: batched vs single fits (brief: "agree ... to 1e-10")


def _caps(rng, k, n, radius, cap):
    """(k, n, 3) points on spherical caps of polar half-angle ``cap``, random poses,
    offsets up to 500 mm and 1 µm noise."""
    polar = np.arccos(rng.uniform(np.cos(cap), 1.0, (k, n)))
    azimuth = rng.uniform(0, 2 * np.pi, (k, n))
    unit = np.stack(
        [np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)], axis=2
    )
    rot = Rotation.random(k, random_state=int(rng.integers(2**31))).as_matrix()
    pts = np.einsum("kij,knj->kni", rot, radius * unit)
    return pts + rng.uniform(-500, 500, (k, 1, 3)) + 1e-3 * rng.standard_normal((k, n, 3))


def _arcs(rng, k, n, radius, arc, dim):
    theta = rng.uniform(0, arc, (k, n))
    flat = radius * np.stack([np.cos(theta), np.sin(theta), np.zeros((k, n))], axis=2)
    flat = flat + 1e-3 * rng.standard_normal((k, n, 3))
    if dim == 2:
        return flat[..., :2] + rng.uniform(-500, 500, (k, 1, 2))
    rot = Rotation.random(k, random_state=int(rng.integers(2**31))).as_matrix()
    return np.einsum("kij,knj->kni", rot, flat) + rng.uniform(-500, 500, (k, 1, 3))


@pytest.mark.parametrize(("cap", "n"), [(np.pi / 2, 25), (0.5, 12), (np.pi, 8)])
def test_spheres_agree_with_single_fits(cap, n):
    rng = np.random.default_rng(1)
    pts = _caps(rng, 40, n, 12.4875, cap)
    batch = fit_spheres(pts)
    assert batch.success.all() and batch.centres.shape == (40, 3)
    for k in range(40):
        single = fit_sphere(pts[k])
        assert np.abs(batch.centres[k] - single.element.centre).max() < AGREE
        assert abs(batch.radii[k] - single.element.radius) < AGREE
        np.testing.assert_allclose(batch.residuals[k], single.residuals, atol=AGREE)
        assert batch.form_error[k] == pytest.approx(single.form_error, abs=AGREE)
        assert batch.rms[k] == pytest.approx(single.rms, abs=AGREE)


def test_known_radius_sphere_centres_agree_with_single_fits():
    """SAMBA-style ball centres from 5 stylus-centre points with the radius known."""
    rng = np.random.default_rng(2)
    pts = _caps(rng, 50, 5, 12.4875, np.pi / 2)
    batch = fit_spheres(pts, radius=12.4875)
    assert np.all(batch.radii == 12.4875)
    for k in range(50):
        single = fit_sphere(pts[k], radius=12.4875)
        assert np.abs(batch.centres[k] - single.element.centre).max() < AGREE


@pytest.mark.parametrize(("arc", "dim"), [(2 * np.pi, 2), (1.0, 2), (2 * np.pi, 3), (1.5, 3)])
def test_circles_agree_with_single_fits(arc, dim):
    rng = np.random.default_rng(3)
    pts = _arcs(rng, 40, 10, 31.75, arc, dim)
    batch = fit_circles(pts)
    assert batch.success.all()
    for k in range(40):
        single = fit_circle(pts[k])
        assert np.abs(batch.centres[k] - single.element.centre).max() < AGREE
        assert abs(batch.radii[k] - single.element.radius) < AGREE
        np.testing.assert_allclose(batch.residuals[k], single.residuals, atol=AGREE)
        if dim == 3:
            assert np.abs(batch.normals[k] - single.element.normal).max() < AGREE
        else:
            assert batch.normals is None


@pytest.mark.parametrize("dim", [2, 3])
def test_planes_and_lines_agree_with_single_fits(dim):
    rng = np.random.default_rng(4)
    pts = rng.normal(size=(30, 12, dim)) * ([50.0, 1.0, 0.01][:dim]) + rng.uniform(
        -500, 500, (30, 1, dim)
    )
    lines = fit_lines(pts)
    for k in range(30):
        single = fit_line(pts[k])
        assert np.abs(lines.directions[k] - single.element.direction).max() < AGREE
        assert np.abs(lines.points[k] - single.element.point).max() < AGREE
        np.testing.assert_allclose(lines.residuals[k], single.residuals, atol=AGREE)
        assert lines.form_error[k] == pytest.approx(single.form_error, abs=AGREE)
    if dim == 3:
        planes = fit_planes(pts)
        for k in range(30):
            single = fit_plane(pts[k])
            assert np.abs(planes.normals[k] - single.element.normal).max() < AGREE
            np.testing.assert_allclose(planes.residuals[k], single.residuals, atol=AGREE)
            assert planes.form_error[k] == pytest.approx(single.form_error, abs=AGREE)


def test_exact_spheres_recovered_in_many_chunks():
    """More sets than one internal chunk (1024): every exact sphere is recovered to 1e-9."""
    rng = np.random.default_rng(5)
    k = 2500
    centres = rng.uniform(-300, 300, (k, 3))
    radii = rng.uniform(5, 30, k)
    unit = rng.normal(size=(k, 7, 3))
    unit /= np.linalg.norm(unit, axis=2, keepdims=True)
    batch = fit_spheres(centres[:, None, :] + radii[:, None, None] * unit)
    assert np.abs(batch.centres - centres).max() < 1e-9
    assert np.abs(batch.radii - radii).max() < 1e-9
    assert batch.form_error.max() < 1e-9
    assert batch.nit.max() <= 10
    assert batch.message == "spheres: all 2500 fits converged"


def test_poor_algebraic_starts_are_rescued():
    """Short noisy arcs bias the Kåsa start strongly; the batched Gauss–Newton (with its
    Levenberg–Marquardt safeguard) still reaches the same minimum as the single fits."""
    rng = np.random.default_rng(6)
    theta = rng.uniform(0, 0.6, (20, 8))
    pts = 40.0 * np.stack([np.cos(theta), np.sin(theta)], axis=2)
    pts = pts + 0.05 * rng.standard_normal(pts.shape)
    batch = fit_circles(pts)
    assert batch.success.all()
    for k in range(20):
        single = fit_circle(pts[k])
        assert np.abs(batch.centres[k] - single.element.centre).max() < 1e-8
        assert abs(batch.radii[k] - single.element.radius) < 1e-8


@pytest.mark.parametrize(
    ("call", "pattern"),
    [
        (lambda: fit_spheres(np.zeros((3, 5, 2))), r"shape \(K, n, 3\)"),
        (lambda: fit_spheres(np.zeros((5, 3))), "shape"),
        (lambda: fit_spheres(np.ones((2, 3, 3))), "fewer than the 4"),
        (lambda: fit_spheres(np.random.default_rng(0).normal(size=(2, 6, 3)) * [1, 1, 0]), "set 0"),
        (
            lambda: fit_spheres(np.random.default_rng(0).normal(size=(3, 6, 3)), radius=0.0),
            "radius",
        ),
        (
            lambda: fit_circles(np.stack([np.ones((6, 2)), np.outer(np.arange(6.0), [1, 1])])),
            "set 0",
        ),
        (lambda: fit_planes(np.array([np.outer(np.arange(5.0), [1, 2, 3])])), "collinear"),
        (lambda: fit_lines(np.ones((2, 4, 3))), "coincident"),
        (lambda: fit_lines(np.full((2, 4, 3), np.nan)), "NaN or inf"),
        (lambda: fit_circles(np.zeros((0, 5, 2))), "K = 0"),
    ],
)
def test_degenerate_sets_raise_fit_error_naming_the_set(call, pattern):
    with pytest.raises(FitError, match=pattern):
        call()


def test_coplanar_set_is_named_by_its_index_beyond_the_first_chunk():
    rng = np.random.default_rng(7)
    pts = rng.normal(size=(1500, 6, 3))
    pts[1234, :, 2] = 0.0
    with pytest.raises(FitError, match="set 1234"):
        fit_spheres(pts)


def test_ill_posed_sets_do_not_stop_the_batch():
    """Nearly flat sets (1 µm thick over 100 mm) have no meaningful sphere: the radius
    runs away and the normal equations may go singular.  Such a set ends flagged not
    converged or with a radius far beyond the data; the well-posed set in the same
    batch is still fitted exactly."""
    rng = np.random.default_rng(8)
    pts = rng.normal(size=(5, 12, 3)) * [50.0, 50.0, 1e-3]
    unit = rng.normal(size=(12, 3))
    pts[0] = unit / np.linalg.norm(unit, axis=1, keepdims=True)
    batch = fit_spheres(pts)
    assert batch.success[0]
    assert batch.radii[0] == pytest.approx(1.0, abs=1e-12)
    flat = batch.success[1:]
    assert np.all(~flat | (batch.radii[1:] > 1e4))
    assert not flat.all()
    assert f"{int((~batch.success).sum())} of 5 fits did not converge" in batch.message
