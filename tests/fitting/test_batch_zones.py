"""Batched minimum zones (fitting.batch_zones) against the per-set solvers."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from mtmetrology.errors import ConvergenceError
from mtmetrology.fitting import (
    FitError,
    MinimumZoneCylindricity,
    MinimumZoneFlatness,
    MinimumZoneRoundness,
    MinimumZoneSphereDiameter,
    MinimumZoneSphericity,
    minimax,
    minimum_zone,
)
from mtmetrology.fitting import batch_zones as bz
from mtmetrology.fitting.minimum_zone import ZoneStatus

SETS = 40
POINTS = 25
AGREE = 1e-9  # mm: the tolerance against the per-set solver


def shells(kind: str, n_sets: int = SETS, seed: int = 5) -> np.ndarray:
    """Generic sets: form deviations (σ) from 0.1 µm to 40 µm, zones up to 1.5 % of the size."""
    rng = np.random.default_rng(seed)
    form = np.geomspace(1e-4, 0.04, n_sets)[:, None, None]
    if kind == "sphere":
        u = rng.standard_normal((n_sets, POINTS, 3))
        pts = 12.4875 * u / np.linalg.norm(u, axis=2, keepdims=True)
    elif kind == "ring":
        t = rng.uniform(0.0, 2.0 * np.pi, (n_sets, POINTS))
        pts = np.stack([20.0 * np.cos(t), 20.0 * np.sin(t), np.zeros_like(t)], axis=2)
    elif kind == "cylinder":
        t, z = (
            rng.uniform(0.0, 2.0 * np.pi, (n_sets, POINTS)),
            rng.uniform(-10, 10, (n_sets, POINTS)),
        )
        pts = np.stack([28.8 * np.cos(t), 28.8 * np.sin(t), z], axis=2)
    else:
        pts = np.concatenate(
            [rng.uniform(-50.0, 50.0, (n_sets, POINTS, 2)), np.zeros((n_sets, POINTS, 1))], 2
        )
    pts = pts + form * rng.standard_normal(pts.shape)
    rot = Rotation.random(n_sets, random_state=seed).as_matrix()
    return np.einsum("kij,knj->kni", rot, pts) + rng.uniform(-300.0, 300.0, (n_sets, 1, 3))


CASES = [
    ("sphere", bz.minimum_zone_sphericity, minimum_zone.sphericity),
    ("ring", bz.minimum_zone_roundness, minimum_zone.roundness),
    ("plane", bz.minimum_zone_flatness, minimum_zone.flatness),
    ("cylinder", bz.minimum_zone_cylindricity, minimum_zone.cylindricity),
]


def per_set(solve, sets):
    zones = [solve(p) for p in sets]
    return np.array([z.form_error for z in zones]), np.array([z.bounds for z in zones])


@pytest.mark.parametrize(("kind", "batched", "solve"), CASES, ids=[c[0] for c in CASES])
def test_equals_the_per_set_solver(kind, batched, solve):
    """Form error and zone bounds of every set equal the per-set solver's to 1e-9 mm,
    with every set (not one) solved by the batched exchange."""
    sets = shells(kind)
    fit = batched(sets)
    zones = [solve(p) for p in sets]
    assert not fit.fallback.any(), fit.message
    np.testing.assert_allclose(fit.form_error, [z.form_error for z in zones], rtol=0, atol=AGREE)
    np.testing.assert_allclose(fit.bounds, [z.bounds for z in zones], rtol=0, atol=AGREE)
    # The minimum zone is never wider than the least-squares peak-to-valley.
    assert np.all(fit.form_error <= [z.least_squares_form_error + 1e-12 for z in zones])


@pytest.mark.parametrize(("kind", "batched", "solve"), CASES, ids=[c[0] for c in CASES])
def test_the_fallback_path_gives_the_same_zones(kind, batched, solve):
    """max_iterations = 0 sends every set to the per-set solver; fewer steps than some sets
    need leave those unsettled (sent on) and settle the others: the mixed result is still
    the per-set one."""
    sets = shells(kind, 12, seed=9)
    width, bounds = per_set(solve, sets)
    none = batched(sets, max_iterations=0)
    assert none.fallback.all()
    np.testing.assert_array_equal(none.form_error, width)
    steps = batched(sets).iterations
    mixed = batched(sets, max_iterations=int(steps.max()) - 1)
    np.testing.assert_array_equal(mixed.fallback, steps == steps.max())
    np.testing.assert_allclose(mixed.form_error, width, rtol=0, atol=AGREE)
    np.testing.assert_allclose(mixed.bounds, bounds, rtol=0, atol=AGREE)


@pytest.mark.parametrize(("kind", "batched", "solve"), CASES, ids=[c[0] for c in CASES])
def test_zones_far_from_flat_or_round_go_to_the_per_set_solver(kind, batched, solve):
    """Form deviations of 5 % of the size: every set is wider than MAX_RELATIVE_WIDTH of
    its size, is handed on, and gets the per-set solver's zone (the hull's global one
    for flatness, which a local iteration can miss at such widths)."""
    rng = np.random.default_rng(4)
    sets = shells(kind, 4, seed=12)
    sets += 0.05 * 20.0 * rng.standard_normal(sets.shape)
    fit = batched(sets)
    assert fit.fallback.all()
    np.testing.assert_array_equal(fit.form_error, per_set(solve, sets)[0])


def test_exact_zones_of_constructed_sets():
    """Closed forms: a 12-point ring alternating between radii 10 ± 1 µm has roundness
    2 µm; a sphere's six axis points at 10 + (1, 1, -1, -1, 1, 1) µm (±x, ±y, ±z) have
    sphericity 2 µm (a centre shift e moves an outer point out by |e_x| or |e_z| and an
    inner one in by |e_y|, to first order); a unit square with its centre raised 3 µm has
    flatness 3 µm."""
    t = np.linspace(0.0, 2.0 * np.pi, 12, endpoint=False)
    r = 10.0 + 0.001 * np.where(np.arange(12) % 2, 1.0, -1.0)
    ring = np.c_[r * np.cos(t), r * np.sin(t), np.zeros(12)]
    assert bz.minimum_zone_roundness([ring]).form_error[0] == pytest.approx(0.002, abs=1e-12)
    u = np.vstack([np.eye(3), -np.eye(3)])[[0, 3, 1, 4, 2, 5]]
    ball = (10.0 + 0.001 * np.array([1, 1, -1, -1, 1, 1]))[:, None] * u
    assert bz.minimum_zone_sphericity([ball]).form_error[0] == pytest.approx(0.002, abs=1e-12)
    plate = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, 0.5, 0.003]]
    assert bz.minimum_zone_flatness([plate]).form_error[0] == pytest.approx(0.003, abs=1e-12)


def test_rigid_motion_and_scale():
    """The zone width is invariant under a rigid motion and scales with the points."""
    sets = shells("sphere", 10, seed=3)
    rot = Rotation.random(random_state=4).as_matrix()
    base = bz.minimum_zone_sphericity(sets).form_error
    moved = bz.minimum_zone_sphericity(sets @ rot.T + [40.0, -7.0, 2.0]).form_error
    np.testing.assert_allclose(moved, base, rtol=0, atol=1e-12)
    np.testing.assert_allclose(bz.minimum_zone_sphericity(3.0 * sets).form_error, 3.0 * base)


def test_a_set_the_per_set_solver_cannot_settle_raises(monkeypatch):
    sets = shells("sphere", 3)

    def stalls_on_set_one(points):
        zone = minimum_zone.sphericity(points)
        if np.array_equal(points, sets[1]):
            return dataclasses.replace(zone, status=ZoneStatus.ITERATION_LIMIT)
        return zone

    monkeypatch.setattr(minimax, "sphericity", stalls_on_set_one)
    with pytest.raises(ConvergenceError, match="sphericity: set 1: no convergence in"):
        bz.minimum_zone_sphericity(sets, max_iterations=0)


def test_bad_sets_are_refused_by_index():
    sets = shells("sphere", 4)
    sets[2, 7, 1] = np.nan
    with pytest.raises(FitError, match="first: set 2"):
        bz.minimum_zone_sphericity(sets)
    flat = shells("plane", 3)
    flat[1] = np.linspace(0, 1, POINTS)[:, None] * [1.0, 2.0, 3.0]
    with pytest.raises(FitError, match="collinear; first: set 1"):
        bz.minimum_zone_flatness(flat)


def test_the_features_evaluate_all_sets_through_the_batched_solver(monkeypatch):
    """value() of the zone features is the batched solution (the loop
    is not called), shaped as the leading axes, and the minimax diameter is
    r_in + r_out - d_tip of each set."""

    def no_loop(*args):
        raise AssertionError("the per-set loop was called")

    monkeypatch.setattr("mtmetrology.fitting.zone_features._zones", no_loop)
    sets = shells("sphere", 6)
    got = MinimumZoneSphereDiameter(tip_diameter=5.925).value(sets.reshape(2, 3, POINTS, 3))
    bounds = per_set(minimum_zone.sphericity, sets)[1]
    assert got.shape == (2, 3)
    np.testing.assert_allclose(got.ravel(), bounds.sum(axis=1) - 5.925, rtol=0, atol=AGREE)
    for feature, kind, solve in [
        (MinimumZoneCylindricity(), "cylinder", minimum_zone.cylindricity),
        (MinimumZoneSphericity(), "sphere", minimum_zone.sphericity),
        (MinimumZoneRoundness(), "ring", minimum_zone.roundness),
        (MinimumZoneFlatness(), "plane", minimum_zone.flatness),
    ]:
        sets = shells(kind, 5, seed=21)
        np.testing.assert_allclose(feature.value(sets), per_set(solve, sets)[0], rtol=0, atol=AGREE)
