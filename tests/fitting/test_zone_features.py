"""Tests for mtmetrology.fitting.zone_features (minimum-zone features): values, and the
active-set Jacobians against differences."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import mtmetrology.fitting as fitting
from mtmetrology.errors import ConvergenceError, RankDeficientError
from mtmetrology.fitting import (
    Cylindricity,
    Feature,
    Flatness,
    MinimumZoneCylinderDiameter,
    MinimumZoneCylindricity,
    MinimumZoneFlatness,
    MinimumZoneRoundness,
    MinimumZoneSphereDiameter,
    MinimumZoneSphericity,
    Roundness,
    Sphericity,
    minimum_zone,
)
from mtmetrology.fitting import zone_features as zf
from mtmetrology.fitting.minimum_zone import ZoneStatus

NOISE = 2e-3  # mm: form deviations of a few µm, a generic contact set


def _posed(local, seed, offset):
    return local @ Rotation.random(random_state=seed).as_matrix().T + offset


def sphere_task(seed, n=14):
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((n, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return [3.0, -2.0, 5.0] + 12.4875 * u + NOISE * rng.standard_normal((n, 3))


def ring_task(seed, n=12):
    rng = np.random.default_rng(seed)
    t = rng.uniform(0, 2 * np.pi, n)
    local = np.c_[20 * np.cos(t), 20 * np.sin(t), np.zeros(n)]
    return _posed(local + NOISE * rng.standard_normal((n, 3)), seed, [10.0, 5.0, -3.0])


def plane_task(seed, n=12):
    rng = np.random.default_rng(seed)
    local = np.c_[rng.uniform(-50, 50, (n, 2)), NOISE * rng.standard_normal(n)]
    return _posed(local, seed, [0.0, 40.0, 7.0])


def cylinder_task(seed, n=10):
    rng = np.random.default_rng(seed)
    t, z = rng.uniform(0, 2 * np.pi, n), rng.uniform(-10, 10, n)
    local = np.c_[12 * np.cos(t), 12 * np.sin(t), z] + NOISE * rng.standard_normal((n, 3))
    return _posed(local, seed, [100.0, 0.0, 50.0])


FEATURES = [
    (MinimumZoneSphericity(), sphere_task, 5),
    (MinimumZoneSphereDiameter(tip_diameter=5.925), sphere_task, 5),
    (MinimumZoneRoundness(), ring_task, None),  # every point moves the LS plane
    (MinimumZoneFlatness(), plane_task, 4),
    (MinimumZoneCylindricity(), cylinder_task, 6),
    (MinimumZoneCylinderDiameter(inner=False, tip_diameter=5.925), cylinder_task, 6),
]
IDS = [type(f).__name__ for f, _, _ in FEATURES]


def _central(feature, pts, h=1e-7):
    flat = pts.reshape(-1)
    steps = np.eye(flat.size) * h
    plus = feature.value((flat + steps).reshape(-1, *pts.shape))
    minus = feature.value((flat - steps).reshape(-1, *pts.shape))
    return ((plus - minus) / (2 * h))[None, :]


@pytest.mark.parametrize(("feature", "task", "contacts"), FEATURES, ids=IDS)
def test_jacobian_matches_central_differences(feature, task, contacts):
    """Generic random sets (2 µm form): the active-set derivative is exact, so it meets
    central differences (h = 0.1 nm, well inside the contact set's stability) to 1e-6 of
    the largest entry — the differences' own error (solver tolerance / h)."""
    pts = task(1)  # one generic set: 2 x 3n minimax solves
    zone = feature.value(pts)
    assert np.isfinite(zone)
    analytic = feature.jacobian(pts)
    assert analytic.shape == (1, pts.size)
    touching = np.count_nonzero(np.abs(analytic).reshape(-1, 3).sum(axis=1))
    assert touching == (contacts or len(pts))
    numeric = _central(feature, pts)
    assert np.abs(analytic - numeric).max() <= 1e-6 * np.abs(numeric).max()


@pytest.mark.parametrize(("feature", "task", "contacts"), FEATURES, ids=IDS)
def test_jacobian_obeys_the_invariances_of_the_zone(feature, task, contacts):
    """Exact identities: a translation leaves the zone unchanged (Σ_k ∂g/∂q_k = 0), so
    does a rotation (Σ_k q_k × ∂g/∂q_k = 0), and a scaling about the origin scales the
    zone width or the untipped diameter (Euler: Σ_k q_k·∂g/∂q_k = g(q) for degree 1)."""
    pts = task(3) - task(3).mean(axis=0)  # about the centroid: no cancellation
    g = feature.jacobian(pts).reshape(-1, 3)
    scale = np.abs(g).max()
    assert np.abs(g.sum(axis=0)).max() <= 1e-9 * scale
    assert np.abs(np.cross(pts, g).sum(axis=0)).max() <= 1e-9 * scale * np.abs(pts).max()
    tip = getattr(feature, "tip_diameter", 0.0)
    untipped = float(feature.value(pts)) + (tip if not getattr(feature, "inner", True) else -tip)
    assert float(np.sum(pts * g)) == pytest.approx(untipped, rel=1e-9)


@pytest.mark.parametrize(
    ("zone_feature", "ls_feature", "task"),
    [
        (MinimumZoneSphericity(), Sphericity(), sphere_task),
        (MinimumZoneRoundness(), Roundness(), ring_task),
        (MinimumZoneFlatness(), Flatness(), plane_task),
        (MinimumZoneCylindricity(), Cylindricity(), cylinder_task),
    ],
)
def test_minimum_zone_is_at_most_the_least_squares_form_error(zone_feature, ls_feature, task):
    """The LS element's zone is one admissible zone: W_MZ ≤ W_LS, set by set, and the
    stacked value equals the one-at-a-time values."""
    trials = np.stack([[task(10 * i + j) for j in range(2)] for i in range(2)])
    values = zone_feature.value(trials)
    assert values.shape == (2, 2)
    assert np.all(values <= ls_feature.value(trials) + 1e-12)
    assert np.all(values > 0)
    for i in range(2):
        for j in range(2):
            assert values[i, j] == zone_feature.value(trials[i, j])
    assert isinstance(zone_feature, Feature)


def test_known_zones_and_diameters():
    """Constructed zones: an octahedron of radii 10 ± 1 µm (spheres), a 12-gon of radii
    20 ± 0.5 µm, a bore of radii 12 ± 1 µm probed with a Ø 6 mm tip."""
    u = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
    r = 10 + 0.001 * np.array([1, 1, -1, -1, 1, 1])
    ball = r[:, None] * u + [50.0, 60.0, 70.0]
    assert float(MinimumZoneSphericity().value(ball)) == pytest.approx(0.002, abs=1e-12)
    assert float(MinimumZoneSphereDiameter().value(ball)) == pytest.approx(20.0, abs=1e-12)
    cavity = MinimumZoneSphereDiameter(tip_diameter=2.0, inner=True).value(ball)
    assert float(cavity) == pytest.approx(22.0, abs=1e-12)
    t = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    rr = 12 + 0.001 * np.cos(4 * t)
    ring = np.c_[rr * np.cos(t), rr * np.sin(t), np.zeros(8)]
    bore = np.r_[ring, ring + np.array([0, 0, 15])]
    assert float(MinimumZoneCylindricity().value(bore)) == pytest.approx(0.002, abs=1e-9)
    d = MinimumZoneCylinderDiameter(inner=True, tip_diameter=6.0).value(bore)
    assert float(d) == pytest.approx(30.0, abs=1e-9)
    shaft = MinimumZoneCylinderDiameter(inner=False, tip_diameter=6.0).value(bore)
    assert float(shaft) == pytest.approx(18.0, abs=1e-9)


def test_known_roundness_and_flatness():
    """A 12-gon of radii 20 ± 0.5 µm in a tilted plane; a 3 × 3 grid whose corners are
    raised by 4 µm: the zone is 4 µm wide whatever the pose."""
    t = np.arange(12) * np.pi / 6
    r = 20 + 0.0005 * (-1.0) ** np.arange(12)
    ring = _posed(np.c_[r * np.cos(t), r * np.sin(t), np.zeros(12)], 3, [1.0, 2.0, 3.0])
    assert float(MinimumZoneRoundness().value(ring)) == pytest.approx(0.001, abs=1e-12)
    x, y = np.meshgrid([-30.0, 0.0, 30.0], [-30.0, 0.0, 30.0])
    z = 0.004 * ((np.abs(x) == 30) & (np.abs(y) == 30))
    plate = _posed(np.c_[x.ravel(), y.ravel(), z.ravel()], 4, [0.0, 0.0, 500.0])
    assert float(MinimumZoneFlatness().value(plate)) == pytest.approx(0.004, abs=1e-12)


def test_degenerate_zone_has_no_jacobian():
    """Zero form error: every point touches the zone, which is not differentiable."""
    rng = np.random.default_rng(5)
    u = rng.standard_normal((12, 3))
    exact = 10.0 * u / np.linalg.norm(u, axis=1, keepdims=True)
    with pytest.raises(RankDeficientError) as info:
        MinimumZoneSphericity().jacobian(exact)
    assert "Monte Carlo" in str(info.value)


def test_a_set_that_does_not_converge_raises():
    """A zone whose iteration stopped short never becomes a number."""
    second = sphere_task(2)

    def stalls_on_the_second_set(points):
        zone = minimum_zone.sphericity(points)
        if np.array_equal(points, second):
            return dataclasses.replace(zone, status=ZoneStatus.ITERATION_LIMIT)
        return zone

    sets = np.stack([sphere_task(1), second])
    with pytest.raises(ConvergenceError, match="set 1"):
        zf._zones(sets, stalls_on_the_second_set, "minimum_zone_sphericity")


def test_invalid_input_is_refused():
    with pytest.raises(ValueError, match="at least 6"):
        MinimumZoneCylindricity().value(np.zeros((5, 3)))
    with pytest.raises(ValueError, match="one point set"):
        MinimumZoneFlatness().jacobian(np.zeros((2, 5, 3)))
    with pytest.raises(ValueError, match="tip_diameter"):
        MinimumZoneSphereDiameter(tip_diameter=float("nan"))
    for name in [type(f).__name__ for f, _, _ in FEATURES]:
        assert name in fitting.__all__
