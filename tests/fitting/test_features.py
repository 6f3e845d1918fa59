"""Tests of mtmetrology.fitting.features."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.fitting.features import (
    BallCentre,
    CircleDiameter,
    Feature,
    Flatness,
    GaugeLength,
    Roundness,
    SphereDiameter,
    Sphericity,
)
from mtmetrology.fitting.least_squares import fit_circle, fit_plane, fit_sphere

# Seed 000, Table 7-1 (digest 000 §3.12): the two gauge-block points, mm.
Q1 = np.array([-178.6461, -178.6461, 53.1107])
Q2 = np.array([179.1009, 179.0881, 53.1067])
D_TIP = 5.925  # mm, effective tip diameter (digest 000 §2.1, §3.12)
R_STYLUS = (19.05 + D_TIP) / 2  # stylus-centre radius on the Ø 19.05 mm sphere


def test_gauge_length_seed_000_table_7_1_is_499_9966_mm():
    """Digest 000 §3.12 and test T2: ‖q2 − q1‖ = 505.92161 mm, l = 499.9966 mm (±5e-5)."""
    gauge = GaugeLength(tip_diameter=D_TIP)
    pts = np.stack([Q1, Q2])
    assert float(np.linalg.norm(Q2 - Q1)) == pytest.approx(505.92161, abs=5e-6)
    assert float(gauge.value(pts)) == pytest.approx(499.9966, abs=5e-5)
    trials = np.broadcast_to(pts, (4, 7, 2, 3))
    np.testing.assert_allclose(gauge.value(trials), np.full((4, 7), gauge.value(pts)))
    jac = gauge.jacobian(pts)
    e = (Q2 - Q1) / np.linalg.norm(Q2 - Q1)
    np.testing.assert_allclose(jac, np.concatenate([-e, e])[None, :])


def _sphere_task(seed, noise=1e-3, n=25):
    rng = np.random.default_rng(seed)
    polar = np.arccos(rng.uniform(0, 1, n))
    az = rng.uniform(0, 2 * np.pi, n)
    unit = np.column_stack([np.sin(polar) * np.cos(az), np.sin(polar) * np.sin(az), np.cos(polar)])
    pts = np.array([120.0, -40.0, 75.0]) + R_STYLUS * unit
    return pts + noise * rng.standard_normal(pts.shape)


def _ring_task(seed, noise=1e-3, n=16):
    rng = np.random.default_rng(seed)
    theta = np.linspace(0, 2 * np.pi, n, endpoint=False) + 0.1 * rng.standard_normal(n)
    radius = 63.5 / 2 - D_TIP / 2  # ring gauge Ø 63.50 mm probed from inside
    pts = np.column_stack([radius * np.cos(theta), radius * np.sin(theta), np.full(n, -10.0)])
    return pts + noise * rng.standard_normal(pts.shape)


def _plane_task(seed, noise=1e-3, n=12):
    rng = np.random.default_rng(seed)
    pts = np.column_stack([rng.uniform(-80, 80, (n, 2)), np.full(n, 3.0)])
    return pts + noise * rng.standard_normal(pts.shape)


def test_sphere_diameter_of_the_precision_sphere_is_19_05_mm():
    exact = _sphere_task(1, noise=0.0)
    assert float(SphereDiameter(tip_diameter=D_TIP).value(exact)) == pytest.approx(19.05, abs=1e-9)
    cavity = SphereDiameter(tip_diameter=D_TIP, inner=True).value(exact)
    assert float(cavity) == pytest.approx(2 * R_STYLUS + D_TIP, abs=1e-9)


def test_ring_gauge_diameter_is_63_5_mm():
    exact = _ring_task(2, noise=0.0)
    assert float(CircleDiameter(inner=True, tip_diameter=D_TIP).value(exact)) == pytest.approx(
        63.5, abs=1e-9
    )


FEATURES = [
    (SphereDiameter(tip_diameter=D_TIP), _sphere_task, fit_sphere),
    (Sphericity(), _sphere_task, fit_sphere),
    (CircleDiameter(inner=True, tip_diameter=D_TIP), _ring_task, fit_circle),
    (Roundness(), _ring_task, fit_circle),
    (Flatness(), _plane_task, fit_plane),
    (BallCentre(), lambda s: _sphere_task(s, n=8), fit_sphere),
    (BallCentre(radius=R_STYLUS), lambda s: _sphere_task(s, n=5), fit_sphere),
]


@pytest.mark.parametrize(("feature", "task", "fit"), FEATURES, ids=lambda f: type(f).__name__)
def test_vectorised_value_matches_one_at_a_time(feature, task, fit):
    trials = np.stack([[task(10 * i + j) for j in range(3)] for i in range(4)])  # (4, 3, n, 3)
    values = feature.value(trials)
    k = len(feature.output_names)
    assert values.shape == ((4, 3) if k == 1 else (4, 3, k))
    for i in range(4):
        for j in range(3):
            single = np.atleast_1d(feature.value(trials[i, j]))
            np.testing.assert_allclose(np.atleast_1d(values[i, j]), single, atol=1e-10)
    assert isinstance(feature, Feature)


def _central(feature, pts, h=1e-6):
    flat = pts.reshape(-1)
    cols = []
    for m in range(flat.size):
        plus, minus = flat.copy(), flat.copy()
        plus[m] += h
        minus[m] -= h
        cols.append(
            (
                np.atleast_1d(feature.value(plus.reshape(pts.shape)))
                - np.atleast_1d(feature.value(minus.reshape(pts.shape)))
            )
            / (2 * h)
        )
    return np.stack(cols, axis=1)


@pytest.mark.parametrize(("feature", "task", "fit"), FEATURES, ids=lambda f: type(f).__name__)
def test_analytic_jacobian_matches_central_differences(feature, task, fit):
    """With 1 µm noise the first-order fit Jacobians are accurate to O(1e-4) relative
    (module notes of least_squares); tolerance 2e-3 of the largest entry."""
    pts = task(3)
    analytic = feature.jacobian(pts)
    numeric = _central(feature, pts)
    assert analytic.shape == (len(feature.output_names), pts.size)
    assert np.abs(analytic - numeric).max() <= 2e-3 * np.abs(numeric).max()


def test_jacobians_are_exact_for_exact_geometry():
    """Zero form error: the diameter and centre Jacobians agree to 1e-6 relative."""
    for feature, task in [
        (SphereDiameter(tip_diameter=D_TIP), _sphere_task),
        (CircleDiameter(tip_diameter=D_TIP), _ring_task),
        (BallCentre(radius=R_STYLUS), lambda s, noise: _sphere_task(s, noise, n=6)),
    ]:
        pts = task(4, noise=0.0)
        numeric = _central(feature, pts)
        assert np.abs(feature.jacobian(pts) - numeric).max() <= 1e-6 * np.abs(numeric).max()


def test_sphere_diameter_guf_equals_parameter_covariance():
    """G U_q Gᵀ with U_q = σ² I equals 4 × the radius variance of the fit's covariance."""
    pts = _sphere_task(5)
    g = SphereDiameter(tip_diameter=D_TIP).jacobian(pts)
    sigma = 2e-3
    u2 = (g @ (sigma**2 * np.eye(pts.size)) @ g.T).item()
    assert u2 == pytest.approx(4 * fit_sphere(pts).parameter_covariance(sigma)[3, 3], rel=1e-12)


@pytest.mark.parametrize(
    ("call", "pattern"),
    [
        (lambda: GaugeLength(-1.0), "tip_diameter"),
        (lambda: GaugeLength(D_TIP).value(np.zeros((3, 3))), r"\(\.\.\., 2, 3\)"),
        (lambda: GaugeLength(D_TIP).jacobian(np.zeros((2, 2))), r"\(2, 3\)"),
        (lambda: SphereDiameter().value(np.zeros((3, 3))), "at least 4"),
        (lambda: Flatness().jacobian(np.zeros((4, 3, 3))), "one point set"),
        (lambda: BallCentre(radius=0.0), "radius"),
        (lambda: Roundness().value(np.zeros((5, 2))), r"\(\.\.\., n, 3\)"),
    ],
)
def test_invalid_input_is_refused_with_a_clear_message(call, pattern):
    with pytest.raises(ValueError, match=pattern):
        call()


@pytest.mark.parametrize(
    "feature",
    [
        SphereDiameter(),
        CircleDiameter(),
        Flatness(),
        BallCentre(),
    ],
    ids=lambda f: f.name,
)
def test_min_points_is_what_the_fit_refuses_below(feature):
    """``min_points`` (read by ``mtm task uncertainty`` to refuse a short file) is the
    fewest points ``value`` accepts."""
    rng = np.random.default_rng(2)
    d = rng.normal(size=(feature.min_points, 3))
    points = 10.0 * d / np.linalg.norm(d, axis=1, keepdims=True)
    assert np.all(np.isfinite(feature.value(points)))
    short = feature.min_points - 1
    with pytest.raises(ValueError, match=rf"^{feature.name}: needs at least .*, got {short}$"):
        feature.value(points[:-1])
