"""Tests of mtmetrology.fitting.batch_cylinders: batched least-squares cylinders equal the
one-at-a-time fits (:func:`fit_cylinder`) to 1e-10 mm, and bad input is refused."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mtmetrology.fitting import FitError, fit_cylinder
from mtmetrology.fitting.batch_cylinders import fit_cylinders

AGREE = 1e-10  # mm and rad: batched vs single fits, as for the other batch fits


def cylinder_sets(rng, k, n, radius, half_length, arc=2 * np.pi, noise=1e-3):
    """(k, n, 3) points on cylinders of random pose, offsets up to 500 mm, with noise;
    also the rotations (k, 3, 3) (axis = third column) and offsets (k, 3)."""
    theta = rng.uniform(0, arc, (k, n))
    z = rng.uniform(-half_length, half_length, (k, n))
    local = np.stack([radius * np.cos(theta), radius * np.sin(theta), z], axis=2)
    rot = Rotation.random(k, random_state=int(rng.integers(2**31))).as_matrix()
    offset = rng.uniform(-500, 500, (k, 3))
    pts = np.einsum("kij,knj->kni", rot, local) + offset[:, None, :]
    return pts + noise * rng.standard_normal(pts.shape), rot, offset


@pytest.mark.parametrize(
    ("n", "half_length", "arc"),
    [(25, 10.0, 2 * np.pi), (25, 24.5, 2 * np.pi), (25, 3.0, 2 * np.pi), (12, 40.0, 2.0)],
    ids=["bore", "isotropic", "short", "partial-arc"],
)
def test_batched_cylinders_agree_with_single_fits(n, half_length, arc):
    """Long, short, near-isotropic (L ≈ 2.45 R: equal principal variances) and partial
    cylinders, random poses, 1 µm noise: every set equals fit_cylinder to 1e-10."""
    rng = np.random.default_rng(11)
    pts, _, _ = cylinder_sets(rng, 15, n, 20.0, half_length, arc)
    batch = fit_cylinders(pts)
    assert batch.success.all()
    for k in range(len(pts)):
        single = fit_cylinder(pts[k])
        assert abs(batch.radii[k] - single.element.radius) < AGREE
        assert np.abs(batch.directions[k] - single.element.direction).max() < AGREE
        assert np.abs(batch.points[k] - single.element.point).max() < AGREE
        np.testing.assert_allclose(batch.residuals[k], single.residuals, atol=AGREE)
        assert batch.form_error[k] == pytest.approx(single.form_error, abs=AGREE)
        assert batch.rms[k] == pytest.approx(single.rms, abs=AGREE)


def test_given_start_direction_reaches_the_same_cylinders():
    """A nominal axis (here the true one, per set) as the start: same fits."""
    rng = np.random.default_rng(12)
    pts, rot, _ = cylinder_sets(rng, 20, 25, 12.5, 10.0)
    free = fit_cylinders(pts)
    started = fit_cylinders(pts, direction=rot[:, :, 2])
    assert started.success.all()
    np.testing.assert_allclose(started.radii, free.radii, atol=AGREE)
    np.testing.assert_allclose(started.directions, free.directions, atol=AGREE)
    one = fit_cylinders(pts[:1], direction=rot[0, :, 2] * 3.0)  # (3,), any length
    np.testing.assert_allclose(one.radii, free.radii[:1], atol=AGREE)


def test_sparse_sets_start_from_every_axis():
    """Fewer than 10 points: every candidate axis is refined; exact data still gives the
    exact cylinder (two rings of 4 points at random poses)."""
    rng = np.random.default_rng(13)
    t = np.array([0.0, 1.7, 3.1, 4.6])
    ring = np.c_[9.0 * np.cos(t), 9.0 * np.sin(t), np.zeros(4)]
    local = np.r_[ring, (ring + np.array([0, 0, 14.0]))[::-1]]
    rot = Rotation.random(10, random_state=3).as_matrix()
    pts = np.einsum("kij,nj->kni", rot, local) + rng.uniform(-100, 100, (10, 1, 3))
    fit = fit_cylinders(pts)
    assert fit.success.all()
    np.testing.assert_allclose(fit.radii, 9.0, atol=1e-10)
    np.testing.assert_allclose(np.abs(np.sum(fit.directions * rot[:, :, 2], axis=1)), 1.0)


def test_degenerate_and_malformed_sets_are_refused():
    rng = np.random.default_rng(7)
    pts, _, _ = cylinder_sets(rng, 4, 12, 10.0, 5.0)
    flat = pts.copy()
    flat[2, :, 2] = 0.0
    flat[2] = flat[2] @ Rotation.random(random_state=1).as_matrix()  # coplanar set 2
    with pytest.raises(FitError, match="set 2"):
        fit_cylinders(flat)
    bad = pts.copy()
    bad[1, 3, 0] = np.nan
    with pytest.raises(FitError, match="NaN"):
        fit_cylinders(bad)
    with pytest.raises(FitError, match="fewer than the 5"):
        fit_cylinders(pts[:, :4])
    with pytest.raises(FitError, match="direction"):
        fit_cylinders(pts, direction=[0.0, 0.0, 0.0])
    with pytest.raises(FitError, match="direction"):
        fit_cylinders(pts, direction=np.ones((3, 3)))
