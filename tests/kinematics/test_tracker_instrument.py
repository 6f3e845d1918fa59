"""The laser-tracker instrument model (Aguado et al. (2019), eqs 21–24; digest 001 A4.2–A4.4)."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.kinematics.tracker import (
    TrackerLimits,
    TrackerNoise,
    TrackerPose,
    cartesian,
    eq23_variances,
    euler_angles,
    euler_matrix,
    perturb_pose,
    point_covariance,
    spherical,
)

PAPER_POSE = TrackerPose.from_customary(-563.52, 194.37, 677.78, 0.0339, 0.0343, 59.4652)
MESH = np.stack(
    np.meshgrid(
        np.arange(800, 1201, 100.0),
        np.arange(100, 501, 100.0),
        np.arange(200, 401, 100.0),
        indexing="ij",
    ),
    -1,
).reshape(-1, 3)


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


@pytest.mark.parametrize("seed", range(5))
def test_eq22_is_rx_ry_rz_orthonormal_det_one(seed):
    a, b, d = np.random.default_rng(seed).uniform(-3, 3, 3)
    r = euler_matrix(a, b, d)
    np.testing.assert_allclose(r, _rx(a) @ _ry(b) @ _rz(d), atol=1e-15)
    np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-14)
    assert np.linalg.det(r) == pytest.approx(1.0, abs=1e-14)


def test_euler_angles_invert_the_matrix():
    angles = np.random.default_rng(1).uniform(-1.4, 1.4, (50, 3))
    np.testing.assert_allclose(euler_angles(euler_matrix(*angles.T)), angles, atol=1e-12)


def test_sign_convention_positive_delta_turns_tracker_x_to_machine_y():
    """δ = +90°: a point 1 m along machine +y from the tracker is on the tracker's x axis."""
    pose = TrackerPose.from_customary(-1000.0, 0.0, 500.0, 0.0, 0.0, 90.0)
    s = spherical(pose.to_tracker([-1000.0, 1000.0, 500.0]))
    np.testing.assert_allclose(s, [1000.0, 0.0, 0.0], atol=1e-12)


def test_round_trip_machine_tracker_machine_and_spherical():
    p = PAPER_POSE.to_tracker(MESH)
    np.testing.assert_allclose(PAPER_POSE.to_machine(p), MESH, atol=1e-11)
    np.testing.assert_allclose(cartesian(spherical(p)), p, atol=1e-11)


def test_pose_jacobian_matches_central_differences():
    jac = PAPER_POSE.jacobian(MESH)
    x = PAPER_POSE.vector
    for k, h in enumerate([1e-3, 1e-3, 1e-3, 1e-6, 1e-6, 1e-6]):
        up, down = x.copy(), x.copy()
        up[k] += h
        down[k] -= h
        fd = (
            TrackerPose.from_vector(up).to_tracker(MESH)
            - TrackerPose.from_vector(down).to_tracker(MESH)
        ) / (2 * h)
        np.testing.assert_allclose(jac[..., k], fd, atol=1e-6)


def test_paper_pose_geometry_ranges_elevations_and_point_uncertainty():
    """Digest 001 A3.3 (derived from the paper's Study 2 pose, 20 µrad, 4 µm + 0.8 µm/m):
    ranges 1.39–1.85 m, elevations −19.3° to −8.8°, u_p 39.3–51.8 µm (mean 45.5 µm)."""
    s = spherical(PAPER_POSE.to_tracker(MESH))
    assert s[:, 0].min() / 1000 == pytest.approx(1.39, abs=0.005)
    assert s[:, 0].max() / 1000 == pytest.approx(1.85, abs=0.005)
    assert np.degrees(s[:, 2].min()) == pytest.approx(-19.3, abs=0.05)
    assert np.degrees(s[:, 2].max()) == pytest.approx(-8.8, abs=0.05)
    assert np.degrees(s[:, 1].min()) == pytest.approx(-63.4, abs=0.5)
    assert np.degrees(s[:, 1].max()) == pytest.approx(-46.8, abs=0.5)
    cov = point_covariance(PAPER_POSE.to_tracker(MESH), TrackerNoise(u_angle_spread=0.0))
    u_p = np.sqrt(np.trace(cov, axis1=-2, axis2=-1)) * 1000
    assert (u_p.min(), u_p.max(), u_p.mean()) == pytest.approx((39.3, 51.8, 45.5), abs=0.05)


def test_eq23_is_the_diagonal_of_the_full_covariance_which_has_correlations():
    """Eq. 23 (as printed, θ polar) equals diag(J Σ Jᵀ); the full matrix also carries
    correlations between x and y of 0.65–0.91 at the paper's pose, which eq. 23 drops."""
    p = PAPER_POSE.to_tracker(MESH)
    noise = TrackerNoise()
    cov = point_covariance(p, noise)
    np.testing.assert_allclose(
        eq23_variances(p, noise), np.diagonal(cov, axis1=-2, axis2=-1), rtol=1e-12
    )
    corr = cov[:, 0, 1] / np.sqrt(cov[:, 0, 0] * cov[:, 1, 1])
    assert corr.min() > 0.6 and corr.max() > 0.9


@pytest.mark.parametrize("spread_urad", [0.0, 3.0])
def test_first_order_covariance_matches_monte_carlo_within_2_percent(spread_urad):
    """10⁵ noisy readings of one point (level drawn per point): each variance of the MC
    within 2 % of J Σ Jᵀ (its sampling error is √(2/10⁵) = 0.45 %, so 2 % is 4.5 σ)."""
    noise = TrackerNoise(u_angle_spread=spread_urad * 1e-6, level_draw="point", u_smr=0.005)
    p = np.array([800.0, -1200.0, -400.0])
    s = spherical(p)
    rng = np.random.default_rng(3)
    n = 100_000
    noisy = noise.sample_readings(rng, np.broadcast_to(s, (n, 3)))
    pts = cartesian(noisy) + noise.sample_smr(rng, (n,))
    mc = np.cov(pts.T)
    cov = point_covariance(p, noise)
    np.testing.assert_allclose(np.diag(mc), np.diag(cov), rtol=0.02)
    assert abs(mc[0, 1] - cov[0, 1]) < 0.02 * np.sqrt(cov[0, 0] * cov[1, 1])


def test_level_drawn_per_test_is_shared_by_the_points_of_a_test():
    """Per test, the 75 points share one level: the per-test scatter of the angle noise
    then varies between tests by the 3 µrad spread (plus √(1/150) of sampling, ≈1.6 µrad);
    drawn per point, only the sampling part remains."""
    s = np.zeros((2000, 75, 3))
    s[..., 0] = 1000.0
    spread = {}
    for draw in ("test", "point"):
        noise = TrackerNoise(u_range_constant=0.0, u_range_per_length=0.0, level_draw=draw)
        d = noise.sample_readings(np.random.default_rng(0), s) - s
        spread[draw] = d[..., 1].std(axis=1).std()
        assert np.sqrt(np.mean(d[..., 1] ** 2)) == pytest.approx(np.hypot(20e-6, 3e-6), rel=0.01)
    assert spread["test"] == pytest.approx(np.hypot(3e-6, 20e-6 / np.sqrt(150)), rel=0.1)
    assert spread["point"] < 2.0e-6


def test_limits_refuse_too_close_too_steep_and_name_the_point():
    limits = TrackerLimits()
    ok = spherical(PAPER_POSE.to_tracker(MESH))
    limits.check(ok)
    close = ok.copy()
    close[4, 0] = 400.0
    with pytest.raises(InputError, match=r"^mesh point 5: range 0.400 m outside 0.5–15 m"):
        limits.check(close)
    steep = ok.copy()
    steep[0, 2] = np.radians(-50.0)
    with pytest.raises(InputError, match=r"^mesh point 1: elevation -50.00° beyond ±45°"):
        limits.check(steep)


def test_pose_perturbation_on_the_rotation_group():
    """R' stays orthonormal; E|ω|² = 3u² (10⁴ draws, ±5 %); positions scatter by u."""
    rng = np.random.default_rng(5)
    x = perturb_pose(PAPER_POSE, rng, 0.01, 50e-6, 10_000)
    rot = euler_matrix(*x[:, 3:].T)
    np.testing.assert_allclose(
        rot @ np.swapaxes(rot, 1, 2), np.broadcast_to(np.eye(3), rot.shape), atol=1e-14
    )
    rel = PAPER_POSE.rotation.T @ rot
    angle = np.arccos(np.clip((np.trace(rel, axis1=1, axis2=2) - 1) / 2, -1, 1))
    assert np.mean(angle**2) == pytest.approx(3 * (50e-6) ** 2, rel=0.05)
    assert x[:, :3].std(axis=0) == pytest.approx([0.01] * 3, rel=0.05)


def test_pose_file_form_round_trip_and_bad_field():
    doc = PAPER_POSE.to_dict()
    back = TrackerPose.from_dict(doc)
    np.testing.assert_allclose(back.vector, PAPER_POSE.vector, rtol=1e-15)
    with pytest.raises(InputError, match=r"^pose\.yaml: field H_mm must be finite"):
        TrackerPose.from_dict({**doc, "H_mm": "nan"}, "pose.yaml")


def test_source_names_theta_azimuth_but_its_limits_are_elevation_limits():
    """Aguado et al. (2019) call θ "the azimuth angle" and give −45° ≤ θ ≤ 45°, −235° ≤ φ ≤
    235°.  Its own Study 2 pose sees the mesh at azimuths −63° to −47°: read as azimuth
    limits, ±45° would refuse the paper's pose; read as elevation limits (θ polar in eq. 23,
    elevation = 90° − θ) every point is inside.  The code takes the second reading."""
    s = spherical(PAPER_POSE.to_tracker(MESH))
    assert np.all(np.abs(np.degrees(s[:, 1])) > 45.0)  # azimuth: beyond ±45° everywhere
    assert TrackerLimits().within(s).all()  # elevation within ±45°, azimuth within ±235°
