"""Tests for mtmetrology.omm.task (full-covariance GUF, Sepahi Boroujeni (2021), ch. 6–7)."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.fitting.features import GaugeLength, SphereDiameter
from mtmetrology.kinematics.machine import Machine
from mtmetrology.omm.repeatability import sphere_normal
from mtmetrology.omm.task import pose_factors, task_uncertainty
from mtmetrology.uncertainty.coverage import DEFAULT_P
from mtmetrology.units import to_internal

MACHINE = Machine.load("five-axis-wcbxfzyst")
UM = to_internal(1.0, "µm")
# Table 7-1 readings of the gauge-block task (X, Y, Z mm; B, C deg).
READINGS = MACHINE.readings_from_customary(
    {
        "X": [-138.5650, -61.2880],
        "Y": [94.6560, 48.3440],
        "Z": [196.2320, 246.8170],
        "B": [-42.0, -64.0],
        "C": [-293.0, -124.0],
    }
)
RNG = np.random.default_rng(6)
DELTA = RNG.normal(0, 1, MACHINE.n_params) * MACHINE.parameter_scales * 5  # ~5 µm, µrad
_A = MACHINE.parameter_scales[:, None] * RNG.normal(size=(13, 13)) * 2  # row i in its unit
SIGMA = _A @ _A.T  # long-term parameter covariance (PSD, correlated)
V = np.zeros((2, 6, 6))
V[:, :3, :3] = np.array([[0.5, 0.1, 0.05], [0.1, 0.6, -0.02], [0.05, -0.02, 0.4]]) * UM**2
COV_E = np.array([[4.5, -1.7, 0.5], [-1.7, 6.6, 0.7], [0.5, 0.7, 5.8]]) * 1e-5  # mm²
LENGTH = GaugeLength(tip_diameter=2 * MACHINE.tip_radius)


def _task(parameters_scale=1.0, **kw):
    args = dict(reading_covariance=V, unexplained_covariance=COV_E)
    args.update(kw)
    return task_uncertainty(MACHINE, READINGS, DELTA, parameters_scale * SIGMA, LENGTH, **args)


def test_value_is_the_feature_of_the_compensated_points():
    r = _task()
    q = MACHINE.forward(READINGS, DELTA)
    assert r.guf.estimate[0] == pytest.approx(float(LENGTH.value(q)), abs=1e-12)
    assert np.allclose(r.points, q)


def test_calibration_covariance_is_propagated_and_the_groups_add_to_u_squared():
    """Compensated with δ̂ (covariance U_θ = SIGMA), drifted by Σ_lt = SIGMA / 4:
    U_q = ⊕ A_s v_s A_sᵀ + G (U_θ + Σ_lt) Gᵀ + I ⊗ cov(e) exactly (first order), the four
    group variances add to u², and the calibration group scales with U_θ."""
    r = _task(long_term_covariance=SIGMA / 4)
    ev = MACHINE.evaluate(READINGS, DELTA, d_axes=True, d_params=True)
    g = ev.d_params.reshape(6, 13)
    expected = g @ (SIGMA + SIGMA / 4) @ g.T
    for s in range(2):
        a = ev.d_axes[s]
        expected[3 * s : 3 * s + 3, 3 * s : 3 * s + 3] += a @ V[s] @ a.T + COV_E
    assert np.allclose(r.points_covariance, expected, rtol=0, atol=1e-10 * expected.max())
    assert r.long_term == "propagated"
    total = sum(r.shares[k][0] for k in r.shares)
    assert total == pytest.approx(1.0, abs=1e-12)
    c = LENGTH.jacobian(r.points)[0] @ g  # ∂L/∂δ
    u2 = r.guf.standard_uncertainty[0] ** 2
    assert r.shares["calibration"][0] * u2 == pytest.approx(c @ SIGMA @ c, rel=1e-9)
    assert r.shares["long_term_variation"][0] * u2 == pytest.approx(c @ SIGMA @ c / 4, rel=1e-9)
    big = _task(long_term_covariance=SIGMA / 4, parameters_scale=100)
    var_big = big.guf.standard_uncertainty[0] ** 2 * big.shares["calibration"][0]
    assert var_big == pytest.approx(100 * c @ SIGMA @ c, rel=1e-9)


def test_recalibrated_machine_has_no_long_term_term_and_refuses_one():
    r = _task(recalibrated=True)
    assert r.long_term == "recalibrated" and r.shares["long_term_variation"][0] == 0.0
    assert r.to_dict()["measurement_model"]["long_term_variation"] == "recalibrated"
    with pytest.raises(InputError, match="recalibrated"):
        _task(recalibrated=True, long_term_covariance=SIGMA)


def test_gauge_length_uncertainty_from_unexplained_errors_alone():
    """Two independent e along the gauge axis: u² = 2 eᵀ cov(e) e (digest check, ≈ 9 µm)."""
    r = _task(reading_covariance=None, parameters_scale=0.0)  # exact parameters
    q = r.points
    e = (q[1] - q[0]) / np.linalg.norm(q[1] - q[0])
    assert r.guf.standard_uncertainty[0] == pytest.approx(np.sqrt(2 * e @ COV_E @ e), rel=1e-12)
    assert r.shares["unexplained_volumetric_error"][0] == pytest.approx(1.0, abs=1e-9)


def test_guf_agrees_with_a_simulation_of_the_probing_and_the_compensation():
    """10⁴ simulated tasks of the module's model: the fixed workpiece Ψ probed by the
    machine drifted to Δ_t ~ N(δ, Σ_lt) (Population IV) with noise v, compensated with a
    calibration δ̂ ~ N(δ, U_θ) drawn independently, plus e: the spread of the length is
    the GUF's u within 5 % (s.e. of u ≈ 0.7 %)."""
    rng = np.random.default_rng(7)
    trials = 10_000
    psi = MACHINE.forward(READINGS, DELTA)  # the probed points of the workpiece
    drifted = rng.multivariate_normal(DELTA, SIGMA / 4, trials)[:, None, :]
    gamma = MACHINE.inverse(np.broadcast_to(psi, (trials, 2, 3)), READINGS, drifted)
    gamma = gamma + np.einsum(
        "sij,tsj->tsi",
        np.linalg.cholesky(V + 1e-30 * np.eye(6)),
        rng.standard_normal((trials, 2, 6)),
    )
    estimates = rng.multivariate_normal(DELTA, SIGMA, trials)[:, None, :]
    e = rng.multivariate_normal(np.zeros(3), COV_E, (trials, 2))
    lengths = LENGTH.value(MACHINE.forward(gamma, estimates) + e)
    u_mc = lengths.std(ddof=1)
    r = _task(long_term_covariance=SIGMA / 4)
    assert r.guf.standard_uncertainty[0] == pytest.approx(u_mc, rel=0.05)


def test_document_has_outputs_groups_and_points():
    doc = _task().to_dict()
    assert doc["kind"] == "uncertainty-result" and doc["method"] == "guf"
    # it says what it is, for the calibration history (issue 32)
    assert (doc["machine"], doc["category"]) == (MACHINE.name, "task")
    (out,) = doc["outputs"]
    assert out["name"] == "gauge_length" and out["unit"] == "mm" and out["p"] == DEFAULT_P
    assert set(doc["budget_groups"]["gauge_length"]) == {
        "repeatability",
        "calibration",
        "long_term_variation",
        "unexplained_volumetric_error",
    }


def test_sphere_diameter_task_runs_with_the_fitting_jacobian():
    n = 12
    rng = np.random.default_rng(3)
    d = sphere_normal(rng.uniform(0.2, 1.4, n), rng.uniform(0, 2 * np.pi, n))
    centre = np.array([0.0, 0.0, 100.0])
    pts = centre + 12.7 * d
    readings = MACHINE.inverse(pts, np.zeros((n, 6)))
    v = np.zeros((n, 6, 6))
    v[:, :3, :3] = np.eye(3) * UM**2
    exact = np.zeros((13, 13))  # parameters known exactly: repeatability alone
    r = task_uncertainty(
        MACHINE, readings, np.zeros(13), exact, SphereDiameter(), reading_covariance=v
    )
    assert r.guf.estimate[0] == pytest.approx(25.4, abs=1e-9)
    # Nominal machine: ∂f/∂(X, Y, Z) = I, so isotropic 1 µm readings give u(D) = ‖∂D/∂q‖·1 µm.
    jac = SphereDiameter().jacobian(r.points)
    assert r.guf.standard_uncertainty[0] == pytest.approx(np.linalg.norm(jac) * UM, rel=1e-9)
    # With U_θ, the scale errors E_XX1, E_YY1, E_ZZ1 change the diameter: u grows.
    with_cal = task_uncertainty(
        MACHINE, readings, np.zeros(13), SIGMA, SphereDiameter(), reading_covariance=v
    )
    assert with_cal.shares["calibration"][0] > 0


def test_pose_factors_invert_eq_a4_2():
    phi, theta = np.radians([18.0, 90.0]), np.radians([144.0, 300.0])
    approach = -sphere_normal(phi, theta) * 3.0
    f = pose_factors(MACHINE, READINGS, approach)
    assert np.allclose(f[:, 0], phi) and np.allclose(f[:, 1], theta)
    assert np.allclose(f[:, 2:4], READINGS[:, 3:5]) and np.allclose(f[:, 4:], READINGS[:, :3])


def test_eq_6_15_as_printed_is_refused_as_not_psd():
    printed = np.array([[4.5, -1.7, -22.0], [-1.7, 6.6, 0.7], [-22.0, 0.7, 5.8]]) * 1e-5
    with pytest.raises(InputError, match="positive semidefinite"):
        _task(unexplained_covariance=printed)


#: Calibration and long-term parameter terms comparable to E on a 500 mm gauge.
U_THETA = np.diag((MACHINE.parameter_scales * 30.0) ** 2)  # 30 µm, µrad, µm/m
SIGMA_LT = np.diag((MACHINE.parameter_scales * 20.0) ** 2)


def _virtual_gauge_coverage(n_tasks, with_e, seed=0, u_theta=U_THETA, sigma_lt=SIGMA_LT):
    """Coverage of k = 2 intervals of the true 500 mm on a virtual five-axis machine, and
    the mean share of u² from the calibration and the long-term variation.

    The machine was in state δ when calibrated; each task gets a fresh calibration
    δ̂ = δ + ε, ε ~ N(0, U_θ) (the identification error, independent of the task's
    readings), and is probed with the machine drifted to δ + d, d ~ N(0, Σ_lt), at
    random B, C, with E drawn from cov(e) and 0.5 µm repeatability; it is compensated
    with δ̂ and its budget holds U_θ, Σ_lt, v and (``with_e``) cov(e).
    """
    rng = np.random.default_rng(seed)
    delta = rng.normal(size=13) * MACHINE.parameter_scales * 10
    cov_e = np.diag([4.5, 6.6, 5.8]) * 1e-5
    v = np.zeros((2, 6, 6))
    v[:, :3, :3] = np.eye(3) * (0.5 * UM) ** 2
    ends = np.array([[-250.0, 0.0, 50.0], [250.0, 0.0, 50.0]])
    gauge = GaugeLength(tip_diameter=0.0)
    hits, shares = 0, []
    for _ in range(n_tasks):
        start = np.zeros((2, 6))
        start[:, 3] = np.radians(rng.uniform(-60, 60))
        start[:, 4] = np.radians(rng.uniform(-180, 180))
        estimate = rng.multivariate_normal(delta, u_theta)  # a fresh calibration
        true_params = rng.multivariate_normal(delta, sigma_lt)  # the machine at the task
        e = rng.multivariate_normal(np.zeros(3), cov_e, 2)
        readings = MACHINE.inverse(ends - e, start, true_params)
        readings[:, :3] += rng.normal(0.0, 0.5 * UM, (2, 3))
        r = task_uncertainty(
            MACHINE,
            readings,
            estimate,
            u_theta,
            gauge,
            long_term_covariance=sigma_lt,
            reading_covariance=v,
            unexplained_covariance=cov_e if with_e else None,
        )
        hits += abs(r.guf.estimate[0] - 500.0) <= r.guf.expanded_uncertainty[0]
        shares.append(r.shares["calibration"][0] + r.shares["long_term_variation"][0])
    return hits / n_tasks, float(np.mean(shares))


def test_virtual_machine_coverage_of_gauge_tasks_is_95_percent_and_collapses_without_e():
    """500 gauge tasks, each compensated with a fresh calibration: coverage inside the
    two-sided 99 % binomial acceptance region of p = 0.95 (0.925 ... 0.975).

    The parameter terms hold over 40 % of u², so a budget that left them out (the
    former "cancellation") would cover at most 2Φ(1.96·√0.6) − 1 ≈ 0.87 on average:
    outside the region.  Without E in the budget, on a machine whose parameter terms are
    small (2.5 units, 200 tasks), markedly less (below 50 %; Sepahi Boroujeni (2021), §6.5,
    saw 90 % against 39 %).
    """
    coverage, parameter_share = _virtual_gauge_coverage(500, with_e=True)
    assert parameter_share > 0.4
    assert 0.925 <= coverage <= 0.975
    small = np.diag((MACHINE.parameter_scales * 2.5) ** 2)
    without_e, _ = _virtual_gauge_coverage(200, False, seed=1, u_theta=small, sigma_lt=small)
    assert without_e < 0.5
