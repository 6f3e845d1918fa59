"""Batched least-squares cylinders and the cylinder and circle-position features."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import mtmetrology.fitting as fitting
from mtmetrology.errors import ConvergenceError, InputError
from mtmetrology.fitting import (
    CircleCentre,
    CylinderDiameter,
    Cylindricity,
    Feature,
    FitError,
    batch,
    fit_circle,
    fit_cylinder,
    fit_cylinders,
)

AGREE = 1e-10  # mm and rad: batched vs single fits, as for the other batch fits
D_TIP = 5.925  # mm, effective tip diameter (Sepahi Boroujeni (2021), Table 7-1)


def _cylinders(rng, k, n, radius, half_length, arc=2 * np.pi, noise=1e-3):
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
    pts, _, _ = _cylinders(rng, 15, n, 20.0, half_length, arc)
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
    pts, rot, _ = _cylinders(rng, 20, 25, 12.5, 10.0)
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


@pytest.mark.parametrize("inner", [True, False])
def test_exact_diameter_of_exact_cylinders_at_any_orientation(inner):
    """Stylus centres on a cylinder of radius R at random poses: D = 2R ± d_tip exactly
    (1e-9 mm) and zero cylindricity; the axis is recovered."""
    rng = np.random.default_rng(14)
    radius = 31.75 - D_TIP / 2 if inner else 12.0 + D_TIP / 2
    pts, rot, offset = _cylinders(rng, 6, 25, radius, 15.0, noise=0.0)
    d = CylinderDiameter(inner=inner, tip_diameter=D_TIP).value(pts)
    np.testing.assert_allclose(d, 63.5 if inner else 24.0, atol=1e-9)
    assert np.all(Cylindricity().value(pts) < 1e-9)
    fit = fit_cylinders(pts)
    np.testing.assert_allclose(np.abs(np.sum(fit.directions * rot[:, :, 2], axis=1)), 1.0)
    # the reported point lies on the true axis
    off_axis = np.cross(fit.points - offset, rot[:, :, 2])
    assert np.abs(off_axis).max() < 1e-9


def _task_cylinder(seed, noise=1e-3, n=25):
    rng = np.random.default_rng(seed)
    return _cylinders(rng, 1, n, 31.75 - D_TIP / 2, 12.0, noise=noise)[0][0]


def _task_ring(seed, noise=1e-3, n=12):
    rng = np.random.default_rng(seed)
    return _cylinders(rng, 1, n, 20.0, 0.0, noise=noise)[0][0]


FEATURES = [
    (CylinderDiameter(inner=True, tip_diameter=D_TIP), _task_cylinder),
    (CylinderDiameter(inner=False, tip_diameter=D_TIP), _task_cylinder),
    (Cylindricity(), _task_cylinder),
    (CircleCentre(), _task_ring),
]
IDS = ["bore", "shaft", "cylindricity", "circle-centre"]


@pytest.mark.parametrize(("feature", "task"), FEATURES, ids=IDS)
def test_vectorised_value_matches_one_at_a_time(feature, task):
    trials = np.stack([[task(10 * i + j) for j in range(3)] for i in range(2)])  # (2, 3, n, 3)
    values = feature.value(trials)
    k = len(feature.output_names)
    assert values.shape == ((2, 3) if k == 1 else (2, 3, k))
    for i in range(2):
        for j in range(3):
            single = np.atleast_1d(feature.value(trials[i, j]))
            np.testing.assert_allclose(np.atleast_1d(values[i, j]), single, atol=1e-10)
    assert isinstance(feature, Feature)


def _central(feature, pts, h=1e-6):
    flat = pts.reshape(-1)
    steps = np.eye(flat.size) * h
    plus = feature.value((flat + steps).reshape(-1, *pts.shape))  # all columns batched
    minus = feature.value((flat - steps).reshape(-1, *pts.shape))
    return ((plus - minus) / (2 * h)).reshape(flat.size, -1).T


@pytest.mark.parametrize(("feature", "task"), FEATURES, ids=IDS)
def test_analytic_jacobian_matches_central_differences(feature, task):
    """1 µm noise: the first-order fit Jacobians are accurate to O(form / size); the
    tolerance is 2e-3 of the largest entry, as for the other least-squares features."""
    pts = task(3)
    analytic = feature.jacobian(pts)
    numeric = _central(feature, pts)
    assert analytic.shape == (len(feature.output_names), pts.size)
    assert np.abs(analytic - numeric).max() <= 2e-3 * np.abs(numeric).max()


def test_jacobians_are_exact_for_exact_geometry():
    """Zero form error: diameter and centre Jacobians agree with differences to 1e-6."""
    for feature, task in FEATURES[:2] + FEATURES[3:]:
        pts = task(4, noise=0.0)
        numeric = _central(feature, pts)
        assert np.abs(feature.jacobian(pts) - numeric).max() <= 1e-6 * np.abs(numeric).max()


def test_circle_centre_is_the_least_squares_centre():
    pts = _task_ring(5)
    np.testing.assert_allclose(CircleCentre().value(pts), fit_circle(pts).element.centre)


def test_guf_variance_of_the_diameter_is_the_fit_covariance():
    """G U_q Gᵀ with U_q = σ² I equals 4 × the radius variance of the fit's covariance."""
    pts = _task_cylinder(6)
    g = CylinderDiameter().jacobian(pts)
    sigma = 2e-3
    u2 = (g @ g.T).item() * sigma**2
    assert u2 == pytest.approx(4 * fit_cylinder(pts).parameter_covariance(sigma)[6, 6], rel=1e-12)


def test_degenerate_and_malformed_sets_are_refused():
    rng = np.random.default_rng(7)
    pts, _, _ = _cylinders(rng, 4, 12, 10.0, 5.0)
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
    with pytest.raises(ValueError, match="at least 5"):
        CylinderDiameter().value(pts[:, :4])
    with pytest.raises(ValueError, match="one point set"):
        Cylindricity().jacobian(pts)
    with pytest.raises(ValueError, match="tip_diameter"):
        CylinderDiameter(tip_diameter=-1.0)
    assert issubclass(FitError, InputError)


def test_everything_is_exported():
    for name in ("CircleCentre", "CylinderDiameter", "Cylindricity", "fit_cylinders"):
        assert name in fitting.__all__


def test_a_set_that_does_not_converge_raises(monkeypatch):
    """The feature never turns a failed fit into a number."""
    real = batch.fit_cylinders

    def second_fails(points):
        fit = real(points)
        status = fit.status.copy()
        status[1] = 0
        return dataclasses.replace(fit, status=status)

    monkeypatch.setattr(batch, "fit_cylinders", second_fails)
    sets = np.stack([_task_cylinder(1), _task_cylinder(2)])
    with pytest.raises(ConvergenceError, match="set 1"):
        Cylindricity().value(sets)
