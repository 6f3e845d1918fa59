"""The task uncertainty carries the calibration's uncertainty (issue 19).

A task is probed with the machine as it is and compensated with the calibration's
estimate δ̂ = Δ + ε, ε ~ (0, U_θ) independent of the readings: u² contains c G U_θ Gᵀ cᵀ
(module notes of :mod:`mtmetrology.omm.simulator`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy import stats

from mtmetrology.fitting.composite import PointCoordinates
from mtmetrology.fitting.features import GaugeLength
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.omm.task import task_uncertainty
from mtmetrology.samba import (
    calibrate,
    load_artefact,
    load_balls,
    read_poses,
    read_records,
    simulate_records,
)
from mtmetrology.units import to_internal

MACHINE = Machine.load("five-axis-wcbxfzyst")
UM = to_internal(1.0, "µm")
XX = MACHINE.parameter_names.index("E_XX1")
EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "samba"


def _one_axis(u_theta_um_per_m: float, method: str = "guf"):
    """Eqs. 6-8 to 6-12 as a compensated task: φ = 100 mm on X, v = 1 µm², the scale error
    E_XX1 calibrated as δ̂ = −50 µm/m with u(δ̂) as given; the output is x = φ(1 + δ̂)."""
    readings = np.array([[100.0, 0.0, 100.0, 0.0, 0.0, 0.0]])
    delta = np.zeros(MACHINE.n_params)
    delta[XX] = to_internal(-50.0, "µm/m")
    u_theta = np.zeros((MACHINE.n_params, MACHINE.n_params))
    u_theta[XX, XX] = to_internal(u_theta_um_per_m, "µm/m") ** 2
    v = np.zeros((1, 6, 6))
    v[0, 0, 0] = UM**2
    r = task_uncertainty(
        MACHINE,
        readings,
        delta,
        u_theta,
        PointCoordinates(1),
        recalibrated=True,
        reading_covariance=v,
        method=method,
        trials=40_000 if method != "guf" else None,
        seed=19,
    )
    return r, float(delta[XX])


def test_one_axis_closed_form_with_the_estimate_and_with_the_true_value():
    """u² = (1 + δ̂)² v + φ² u²(δ̂) compensated with the estimate (≈ v + φ² u_θ² = 2 µm²,
    the thesis' 1.4 µm "neglecting correlation", §6.2.1), and u² = (1 + δ̂)² v ≈ v = 1 µm²
    when the value is true (u(δ̂) = 0)."""
    phi = 100.0
    r, d = _one_axis(10.0)
    u_theta = to_internal(10.0, "µm/m")
    u2 = r.guf.standard_uncertainty[0] ** 2
    assert r.guf.estimate[0] == pytest.approx(phi * (1 + d), abs=1e-12)  # sign of E_XX1
    assert u2 == pytest.approx((1 + d) ** 2 * UM**2 + phi**2 * u_theta**2, rel=1e-9)
    assert u2 == pytest.approx(UM**2 + phi**2 * u_theta**2, rel=2e-4)
    assert r.shares["calibration"][0] == pytest.approx(0.5, abs=1e-4)
    exact, _ = _one_axis(0.0)
    assert exact.guf.standard_uncertainty[0] ** 2 == pytest.approx((1 + d) ** 2 * UM**2, rel=1e-9)
    assert exact.shares["calibration"][0] == 0.0


def test_monte_carlo_draws_the_parameters_independently_of_the_readings():
    """4·10⁴ trials of the 1-D task: u = √2 µm within 2 % (s.e. of u ≈ 0.35 %); a Monte
    Carlo that correlated Δ with the readings would give 1 µm."""
    r, _ = _one_axis(10.0, method="mcm")
    assert r.mcm.standard_uncertainty[0] / UM == pytest.approx(np.sqrt(2.0), rel=0.02)


def test_without_repeatability_or_e_u_is_the_calibration_contribution():
    no_v = task_uncertainty(
        MACHINE,
        np.array([[100.0, 0.0, 100.0, 0.0, 0.0, 0.0]]),
        np.zeros(MACHINE.n_params),
        np.diag((MACHINE.parameter_scales * 10.0) ** 2),
        PointCoordinates(1),
    )
    assert no_v.guf.standard_uncertainty[0] > 0
    assert no_v.shares["calibration"][0] == pytest.approx(1.0, abs=1e-12)
    assert no_v.long_term == "not given"


# ---------------------------------------------------------------- the SAMBA experiment
N_CALIBRATIONS = 120
NOISE = float(to_internal(1.0, "µm"))
# Table 7-1 readings of the gauge-block task (X, Y, Z mm; B, C deg).
GAUGE = {
    "X": [-138.5650, -61.2880],
    "Y": [94.6560, 48.3440],
    "Z": [196.2320, 246.8170],
    "B": [-42.0, -64.0],
    "C": [-293.0, -124.0],
}


@pytest.fixture(scope="module")
def repeated_calibrations(tmp_path_factory):
    """``N_CALIBRATIONS`` SAMBA calibrations of one virtual machine (13 parameters, 111
    indications, 1 µm noise), each with fresh probing noise and a fresh certificate error of
    the scale bar (drawn from its u), simulated, written, read and identified by the
    library (full Gauss–Newton re-solve each); then the same gauge task, probed on the true
    machine without noise, compensated with each calibration."""
    tmp = tmp_path_factory.mktemp("calibrations")
    m = Machine.load("five-axis-wcbxfzyst", "13")
    artefact = load_artefact(EXAMPLES / "artefact.yaml")
    balls = load_balls(EXAMPLES / "balls.yaml").centres()
    programme = read_poses(EXAMPLES / "poses.csv")
    truth = ParameterSet.load(EXAMPLES / "truth.json", m).vector_for(m)
    bar = artefact.scale_bar
    rng = np.random.default_rng(1919)
    readings = m.readings_from_customary(GAUGE)
    gauge = GaugeLength(tip_diameter=0.0)
    true_length = float(gauge.value(m.forward(readings, truth)))
    errors, u = [], []
    for _ in range(N_CALIBRATIONS):
        records = simulate_records(
            m, truth, balls, programme, artefact, noise=NOISE, seed=rng.integers(2**31)
        )
        records.write(tmp / "records.csv")
        certificate = bar.model_copy(update={"length_mm": bar.length_mm + rng.normal(0, bar.u_mm)})
        stated = artefact.model_copy(update={"scale_bar": certificate})
        cal = calibrate(m, read_records(tmp / "records.csv", m, stated), stated, sigma=NOISE)
        pset = cal.parameters
        r = task_uncertainty(
            m, readings, pset.vector_for(m), pset.covariance, gauge, recalibrated=True
        ).guf
        errors.append(r.estimate[0] - true_length)
        u.append(r.standard_uncertainty[0])
    return np.array(errors), np.array(u)


def test_spread_of_compensated_task_errors_agrees_with_the_stated_u(repeated_calibrations):
    """Σ (error_k / u_k)² over the calibrations within the two-sided 99 % region of χ²(K)
    (K = 120: 83.9 … 163.6): the stated u (calibration share alone, E = 0, no
    repeatability) is the spread of the error a fresh calibration leaves (≈ 2.6 µm here;
    the former budget stated 0.0014 µm)."""
    errors, u = repeated_calibrations
    statistic = float(np.sum((errors / u) ** 2))
    low, high = stats.chi2.ppf([0.005, 0.995], N_CALIBRATIONS)
    assert low <= statistic <= high
    assert np.median(u) > 0.5 * UM


def test_k2_intervals_cover_the_truth_95_percent(repeated_calibrations):
    """The count of |error| ≤ 2u within the two-sided 99 % binomial region of p = 0.95
    (K = 120: 108 … 118)."""
    errors, u = repeated_calibrations
    hits = int(np.sum(np.abs(errors) <= 2 * u))
    low, high = stats.binom.ppf([0.005, 0.995], N_CALIBRATIONS, 0.95)
    assert low <= hits <= high
