"""Tracker verification: mesh, round trip, datum by rank, exact recovery, thermal correction
(digest 001 A4.1, A4.2, A4.5, A4.6; issue 21)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from mtmetrology.errors import InputError
from mtmetrology.kinematics.lengths import pair_lengths
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.kinematics.tracker import TrackerNoise, TrackerPose, cartesian
from mtmetrology.tracker import (
    MachineConditions,
    TrackerCalibration,
    calibrate,
    cte_uncertainty,
    parse_mesh,
    simulate,
)
from mtmetrology.tracker.model import datum, setup_terms, suggestions
from mtmetrology.tracker.setup import measurement_points
from mtmetrology.units import from_internal, to_internal

from .conftest import THREE_TOOLS

SILENT = TrackerNoise(0.0, 0.0, 0.0, 0.0)
ONE_TOOL = np.array([[0.0, 0.0, -100.0]])


def test_paper_mesh_has_75_points_x_fastest(mesh):
    assert mesh.shape == (75, 3)
    np.testing.assert_array_equal(mesh[:2], [[800, 100, 200], [900, 100, 200]])
    assert sorted(set(mesh[:, 2])) == [200.0, 300.0, 400.0]


def test_mesh_outside_travel_is_refused(machine):
    with pytest.raises(InputError, match=r"^--mesh: X = 1300 mm lies outside the travel"):
        parse_mesh("800:1300:100,100:500:100,200:400:100", machine)
    with pytest.raises(InputError, match=r"^--mesh: Y range 'nan:500:100'"):
        parse_mesh("800:1200:100,nan:500:100,200:400:100", machine)


def test_zero_errors_round_trip_tracker_machine_tracker(machine, mesh, pose):
    """Digest A4.2: with zero errors and no noise, the readings mapped back through the pose
    are the nominal points R⁻¹(P + T − T_LT) and back, exactly."""
    meas = simulate(machine, np.zeros(machine.n_params), pose, mesh, ONE_TOOL, noise=SILENT)
    back = pose.to_machine(cartesian(meas.spherical))
    expected = mesh + ONE_TOOL  # XFYZ: the tip at (x, y, z) + tool, errors zero
    np.testing.assert_allclose(back, expected, atol=1e-10)


def test_paper_setup_rank_42_of_57_and_what_it_cannot_see(machine, mesh, pose):
    """Issue 21: one tool offset, six pose unknowns: rank 42 of 57; E_CY1–3 and E_CZ1–3
    are not seen at all, E_ZZ3 ~ E_ZZ1 (three Z levels), E_XZ2 ~ E_BZ2, E_YZ2 ~ E_AZ2."""
    q, t = measurement_points(mesh, ONE_TOOL)
    d = datum(machine, q, t, pose)
    assert (d.rank, d.n_unknowns) == (42, 57)
    partners = dict(d.dropped)
    for n in ("E_CY1", "E_CY2", "E_CY3", "E_CZ1", "E_CZ2", "E_CZ3"):
        assert partners[n] == ()
    assert partners["E_ZZ3"] == ("E_ZZ1",)
    assert partners["E_XZ2"] == ("E_BZ2",)
    assert partners["E_YZ2"] == ("E_AZ2",)
    adds = {
        s["add"]: set(s["identifiable_then"]) for s in suggestions(machine, mesh, ONE_TOOL, pose, d)
    }
    assert {"E_CY1", "E_CZ1", "E_XZ2"} <= adds["a second tool offset 100 mm aside in X and Y"]
    assert "E_ZZ3" in adds["five Z levels over the travel"]
    assert "E_ZZ3" not in adds["a second tool offset 100 mm aside in X and Y"]


@pytest.fixture(scope="module")
def observable_truth(machine, mesh, pose):
    """Random errors of 5–20 µm (µrad) on the parameters the three-tool set-up identifies."""
    q, t = measurement_points(mesh, THREE_TOOLS)
    d = datum(machine, q, t, pose)
    rng = np.random.default_rng(11)
    truth = np.zeros(machine.n_params)
    idx = [machine.parameter_names.index(n) for n in d.kept]
    truth[idx] = rng.uniform(5, 20, len(idx)) * rng.choice([-1, 1], len(idx))
    return truth * machine.parameter_scales, d


def test_zero_noise_identification_recovers_observable_errors_exactly(
    machine, mesh, pose, observable_truth
):
    """Digest A4.6: no noise → the injected observable errors and the pose come back to the
    rounding level, eq. 27 after compensation ≈ 0; the unobservable ones are named."""
    truth, d = observable_truth
    exact = MachineConditions(u_sensor=0.0)
    meas = simulate(machine, truth, pose, mesh, THREE_TOOLS, noise=SILENT, conditions=exact, seed=1)
    cal = calibrate(machine, meas, noise=TrackerNoise(u_smr=1e-6))
    assert cal.success
    # three lateral tools expose the tool's constant yaw (issue 30): identified, here zero
    assert cal.setup_terms.added == ("E_CZ0",)
    assert cal.parameters.names == (*d.kept, "E_CZ0")
    idx = [machine.parameter_names.index(n) for n in d.kept]
    scale = machine.parameter_scales[idx]
    values = cal.parameters.values
    assert abs(values[-1]) < 1e-5 * to_internal(1.0, "µrad")
    np.testing.assert_allclose(values[:-1] / scale, truth[idx] / scale, atol=1e-5)
    np.testing.assert_allclose(cal.pose.vector, pose.vector, atol=1e-8)
    assert cal.mean_distance_final < 1e-8
    assert cal.mean_distance_initial > 0.005
    assert set(cal.datum.dropped_names) == {"E_AZ3", "E_BZ3", "E_CZ3", "E_ZZ3"}


def test_result_file_round_trip_and_predict_reads_it(machine, mesh, pose, observable_truth):
    truth, _ = observable_truth
    meas = simulate(machine, truth, pose, mesh, THREE_TOOLS, seed=2)
    cal = calibrate(machine, meas)
    doc = cal.to_dict()
    back = TrackerCalibration.from_dict(doc, machine)
    np.testing.assert_allclose(back.parameters.values, cal.parameters.values, rtol=1e-12)
    np.testing.assert_allclose(back.parameters.covariance, cal.parameters.covariance, rtol=1e-9)
    np.testing.assert_allclose(back.pose.vector, cal.pose.vector, rtol=1e-12)
    np.testing.assert_allclose(back.residuals, cal.residuals, rtol=1e-12)
    pset = ParameterSet.from_document(doc, machine, "result.json")
    assert pset.names == cal.parameters.names


def test_a_result_asymmetric_by_rounding_reads_back_exactly_symmetric(
    machine, mesh, pose, observable_truth
):
    """Issue 30: a tracker result whose covariance entries near 1e-7 differ from their
    mirrors by 3e-16 (the old elementwise rtol=1e-9 refused it by chance) reads back, both
    covariances exactly symmetric; and what it writes is exactly symmetric."""
    truth, _ = observable_truth
    cal = calibrate(machine, simulate(machine, truth, pose, mesh, THREE_TOOLS, seed=2))
    doc = cal.to_dict()
    for matrix in (doc["covariance"]["matrix"], doc["pose_covariance_mm_rad"]):
        np.testing.assert_array_equal(np.array(matrix), np.array(matrix).T)
    c = np.array(doc["covariance"]["matrix"])
    c[0, 5], c[5, 0] = 1.2e-7, 1.2e-7 + 3e-16  # still PSD here (the reader checks it)
    assert not np.allclose(c, c.T, rtol=1e-9, atol=0)
    doc["covariance"]["matrix"] = c.tolist()
    pc = np.array(doc["pose_covariance_mm_rad"])
    pc[1, 0] += 1e-12 * np.abs(pc).max()
    doc["pose_covariance_mm_rad"] = pc.tolist()
    back = TrackerCalibration.from_dict(doc, machine)
    np.testing.assert_array_equal(back.parameters.covariance, back.parameters.covariance.T)
    np.testing.assert_array_equal(back.pose_covariance, back.pose_covariance.T)


def test_cte_uncertainty_eq10_is_5_77e_4_not_the_printed_0_0006():
    """Eq. 10: u(α) = 0.002/(2√3) = 5.7735e-4 µm/(mm·K); the paper prints 0.0006 (rounded)."""
    u = cte_uncertainty(11.5e-6) / to_internal(1.0, "µm/mm")
    assert u == pytest.approx(5.7735e-4, rel=1e-4)
    assert round(u, 4) == 0.0006 and u != pytest.approx(0.0006, rel=1e-3)
    assert cte_uncertainty(30e-6) == pytest.approx(3e-6 / (2 * np.sqrt(3)))  # 10 % rule


def test_thermal_correction_sign_closed_form(machine, mesh, pose):
    """All axes at 25 °C, α = 11.5 µm/(m·K), no errors: uncorrected, the X scale grows by
    α·ΔT = 57.5 µm/m and E_XX1 (Legendre degree 1 over the 400 mm travel, the tool going
    +x relative to the workpiece) takes α·ΔT·200 mm = +11.5 µm; the correction removes it."""
    warm = MachineConditions(np.full((3, 2), 25.0), u_sensor=0.0, u_cte=np.zeros(3))
    meas = simulate(machine, np.zeros(machine.n_params), pose, mesh, THREE_TOOLS,
                    noise=SILENT, conditions=warm, seed=3)  # fmt: skip
    noise = TrackerNoise(u_smr=1e-6)
    cold = MachineConditions(cte=np.zeros(3), u_sensor=0.0)
    raw = calibrate(machine, meas, noise=noise, conditions=cold)
    fixed = calibrate(machine, meas, noise=noise, conditions=warm)
    um = to_internal(1.0, "µm")
    i = raw.parameters.names.index("E_XX1")
    assert raw.parameters.values[i] / um == pytest.approx(11.5, rel=1e-4)
    assert abs(fixed.parameters.values[i] / um) < 1e-5


def test_pose_inside_workspace_and_beyond_limits_are_refused(machine, mesh):
    inside = TrackerPose.from_customary(1000.0, 300.0, 300.0, 0, 0, 0)
    with pytest.raises(InputError, match=r"^pose: the tracker at D, L, H = 1000, 300, 300 mm"):
        simulate(machine, np.zeros(machine.n_params), inside, mesh, ONE_TOOL)
    above = TrackerPose.from_customary(-600.0, 300.0, 2000.0, 0, 0, 0)
    with pytest.raises(InputError, match=r"^measurement point \d+: elevation -\d+\.\d+° beyond"):
        simulate(machine, np.zeros(machine.n_params), above, mesh, ONE_TOOL)


def test_lateral_tools_expose_a_constant_tool_rotation_and_it_is_identified(machine, mesh, pose):
    """Issue 30: a constant rotation of the spindle side (E_AZ0, E_BZ0, E_CZ0 = 20, −15,
    25 µrad, outside the preset's model) seen with three laterally offset tools of equal
    length.  The rank check adds the tool's yaw E_CZ0 (each lateral tool moves by
    ε × t differently) and names E_AZ0 and E_BZ0 as absorbed (pose, squareness and the
    Z straightness over three Z levels), E_CY0 as the same column as E_CZ0: the zero-noise
    residuals fall to the rounding level and E_CZ0 comes back; with one tool along Z nothing
    is exposed (the shift ε × t is one translation of the pose)."""
    tilted = machine.with_parameters([*machine.parameter_names, "E_AZ0", "E_BZ0", "E_CZ0"])
    truth = np.r_[np.zeros(machine.n_params), 20.0, -15.0, 25.0] * to_internal(1.0, "µrad")
    exact = MachineConditions(u_sensor=0.0)
    meas = simulate(tilted, truth, pose, mesh, THREE_TOOLS, noise=SILENT, conditions=exact, seed=5)
    cal = calibrate(machine, meas, noise=TrackerNoise(u_smr=1e-6))
    assert cal.setup_terms.added == ("E_CZ0",)
    absorbed = dict(cal.setup_terms.absorbed)
    assert set(absorbed) == {"E_AZ0", "E_BZ0", "E_AY0", "E_BY0", "E_CY0"}
    assert absorbed["E_CY0"] == ("E_CZ0",)
    assert cal.to_dict()["setup_terms"]["added"] == ["E_CZ0"]
    assert from_internal(np.linalg.norm(cal.residuals, axis=1).max(), "µm") <= 1e-3
    yaw = cal.parameters.values[cal.parameters.names.index("E_CZ0")]
    assert from_internal(yaw, "µrad") == pytest.approx(25.0, abs=1e-4)
    q, t = measurement_points(mesh, ONE_TOOL)
    one = setup_terms(machine, datum(machine, q, t, pose), q, t, pose)
    assert one.added == () and len(one.absorbed) == 6


def test_held_out_lengths_u_covers_95_percent_with_the_matching_noise(machine, mesh, pose):
    """Issue 30: a modern tracker (u_r = 1 µm + 0.5 µm/m, 10 µrad, no level spread) given to
    the calibration as simulated (``--range-noise 1,0.5 --angle-urad 10 --angle-spread 0``);
    60 virtual set-ups of the three-tool mesh, each with fresh errors (5–20 µm or µrad on
    the datum's parameters and the tool's constant yaw E_CZ0) and fresh noise, and one
    held-out pair of random positions each (with one of the three tools): |L̂ − L| ≤ 2·u(L)
    (u(L) = √(g U_θ gᵀ), both ends' correlation kept) in a count inside the binomial(60,
    0.95) central 99 % region (53..60; it fails when u is half the truth), and Σ z² inside
    the central 99 % region of χ²(60) (it fails when u is twice the truth, e.g. with the
    source's 4 µm + 0.8 µm/m weights, or without the correlation of the two ends)."""
    n_setups = 60
    q, t = measurement_points(mesh, THREE_TOOLS)
    tilted = machine.with_parameters([*datum(machine, q, t, pose).kept, "E_CZ0"])
    noise = TrackerNoise(to_internal(1.0, "µm"), to_internal(0.5, "µm/m"),
                         to_internal(10.0, "µrad"), 0.0)  # fmt: skip
    exact_temperatures = MachineConditions(u_sensor=0.0)
    lo, hi = np.array([800.0, 100.0, 200.0]), np.array([1200.0, 500.0, 400.0])
    z = np.empty(n_setups)
    for k in range(n_setups):
        rng = np.random.default_rng(1000 + k)
        size = tilted.n_params
        truth = rng.uniform(5, 20, size) * rng.choice([-1, 1], size) * tilted.parameter_scales
        meas = simulate(tilted, truth, pose, mesh, THREE_TOOLS, noise=noise,
                        conditions=exact_temperatures, seed=rng)  # fmt: skip
        cal = calibrate(machine, meas, noise=noise, conditions=exact_temperatures)
        m = cal.parameters.machine_for(machine)
        qa, qb = rng.uniform(lo, hi, (2, 1, 3))
        tool = THREE_TOOLS[k % 3]  # the pair measured with one of the tools
        theta = cal.parameters.vector_for(m)
        pred = pair_lengths(m, theta, cal.parameters.covariance, qa, qb, tool=tool)
        ends = [tilted.forward(end, truth, tool=tool) for end in (qa, qb)]
        true_length = np.linalg.norm(ends[1] - ends[0])
        z[k] = (pred.predicted[0] - true_length) / pred.u[0]
    lo_count, hi_count = stats.binom.interval(0.99, n_setups, 0.95)
    assert lo_count <= np.sum(np.abs(z) <= 2.0) <= hi_count
    low, high = stats.chi2.interval(0.99, n_setups)
    assert low <= np.sum(z**2) <= high


def test_summary_figures_say_what_the_residuals_are(machine, mesh, pose):
    """Issue 30: the residuals against noisy readings are the readings' noise: their RMS is
    the noise model's √(mean tr Σ_i) reduced by the redundancy (√((m − n)/m) ≈ 0.96 here),
    stated beside them; the compensation's own size and its u are separate fields."""
    noise = TrackerNoise(to_internal(1.0, "µm"), to_internal(0.5, "µm/m"),
                         to_internal(10.0, "µrad"), 0.0)  # fmt: skip
    exact = MachineConditions(u_sensor=0.0)
    truth = np.zeros(machine.n_params)
    truth[machine.parameter_names.index("E_XX1")] = to_internal(30.0, "µm")
    meas = simulate(machine, truth, pose, mesh, THREE_TOOLS, noise=noise, conditions=exact,
                    seed=7)  # fmt: skip
    cal = calibrate(machine, meas, noise=noise, conditions=exact)
    doc = cal.to_dict()
    rms = np.sqrt(np.mean(np.sum(np.square(doc["residuals_um"]), axis=1)))
    m, n = cal.residuals.size, len(cal.parameters.names) + 6
    assert 0.85 < rms / (doc["noise_rms_um"] * np.sqrt((m - n) / m)) < 1.15
    assert 0 < doc["compensated_u_mean_um"] < doc["noise_rms_um"]
    # without noise: X's positioning error of 30 µm (Legendre degree 1, |P1| = 1, 0.5, 0,
    # 0.5, 1 over the five X levels) moves the points by 30 µm · 0.6 = 18 µm on average
    meas = simulate(machine, truth, pose, mesh, THREE_TOOLS, noise=SILENT, conditions=exact)
    silent = calibrate(machine, meas, noise=TrackerNoise(u_smr=1e-6), conditions=exact)
    assert from_internal(silent.correction_mean, "µm") == pytest.approx(18.0, rel=1e-6)
    back = TrackerCalibration.from_dict(doc, machine)
    assert back.noise_rms == pytest.approx(cal.noise_rms, rel=1e-12)


def test_known_pose_fixed_or_as_prior_limits(machine, mesh, pose):
    """A known pose as a prior of huge variance gives the identified solution; a prior of
    vanishing variance holds the pose at the given one; a fixed pose is not an unknown (zero
    covariance) and then no pose absorbs the tool's constant pitch and roll either: the rank
    check adds E_AZ0 and E_BZ0 beside E_CZ0."""
    meas = simulate(machine, np.zeros(machine.n_params), pose, mesh, THREE_TOOLS, seed=3)
    free = calibrate(machine, meas)
    wide = calibrate(machine, meas, pose=pose, pose_covariance=np.diag([1e6] * 3 + [1.0] * 3))
    assert wide.pose_source == "prior" and wide.parameters.names == free.parameters.names
    scale = np.abs(free.parameters.values).max()
    np.testing.assert_allclose(wide.parameters.values, free.parameters.values, atol=1e-6 * scale)
    tight = np.diag([1e-14] * 3 + [1e-18] * 3)  # 0.1 nm, 1 nrad
    held = calibrate(machine, meas, pose=pose, pose_covariance=tight)
    np.testing.assert_allclose(held.pose.vector, pose.vector, atol=1e-6)
    fixed = calibrate(machine, meas, pose=pose)
    assert fixed.pose_source == "fixed"
    np.testing.assert_array_equal(fixed.pose.vector, pose.vector)
    assert not fixed.pose_covariance.any()
    assert fixed.setup_terms.added == ("E_AZ0", "E_BZ0", "E_CZ0")
    with pytest.raises(InputError, match=r"^pose covariance: not positive definite"):
        calibrate(machine, meas, pose=pose, pose_covariance=-np.eye(6))
