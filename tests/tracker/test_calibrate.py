"""Tracker verification: mesh, round trip, datum by rank, exact recovery, thermal correction
(digest 001 A4.1, A4.2, A4.5, A4.6; issue 21)."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
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
from mtmetrology.tracker.model import datum, suggestions
from mtmetrology.tracker.setup import measurement_points
from mtmetrology.units import to_internal

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
    assert cal.parameters.names == d.kept
    idx = [machine.parameter_names.index(n) for n in d.kept]
    scale = machine.parameter_scales[idx]
    np.testing.assert_allclose(cal.parameters.values / scale, truth[idx] / scale, atol=1e-5)
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
