"""The cylinder and circle-position features (the batched cylinders they run on are in
test_batch_cylinders.py)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_batch_cylinders import cylinder_sets

import mtmetrology.fitting as fitting
from mtmetrology.errors import ConvergenceError, InputError
from mtmetrology.fitting import (
    CircleCentre,
    CylinderDiameter,
    Cylindricity,
    Feature,
    FitError,
    batch_cylinders,
    fit_circle,
    fit_cylinder,
    fit_cylinders,
)

D_TIP = 5.925  # mm, effective tip diameter (Sepahi Boroujeni (2021), Table 7-1)


@pytest.mark.parametrize("inner", [True, False])
def test_exact_diameter_of_exact_cylinders_at_any_orientation(inner):
    """Stylus centres on a cylinder of radius R at random poses: D = 2R ± d_tip exactly
    (1e-9 mm) and zero cylindricity; the axis is recovered."""
    rng = np.random.default_rng(14)
    radius = 31.75 - D_TIP / 2 if inner else 12.0 + D_TIP / 2
    pts, rot, offset = cylinder_sets(rng, 6, 25, radius, 15.0, noise=0.0)
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
    return cylinder_sets(rng, 1, n, 31.75 - D_TIP / 2, 12.0, noise=noise)[0][0]


def _task_ring(seed, noise=1e-3, n=12):
    rng = np.random.default_rng(seed)
    return cylinder_sets(rng, 1, n, 20.0, 0.0, noise=noise)[0][0]


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


def test_malformed_sets_and_tips_are_refused():
    rng = np.random.default_rng(7)
    pts, _, _ = cylinder_sets(rng, 4, 12, 10.0, 5.0)
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
    real = batch_cylinders.fit_cylinders

    def second_fails(points):
        fit = real(points)
        status = fit.status.copy()
        status[1] = 0
        return dataclasses.replace(fit, status=status)

    monkeypatch.setattr(batch_cylinders, "fit_cylinders", second_fails)
    sets = np.stack([_task_cylinder(1), _task_cylinder(2)])
    with pytest.raises(ConvergenceError, match="set 1"):
        Cylindricity().value(sets)
