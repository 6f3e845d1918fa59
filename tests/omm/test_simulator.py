"""Tests for mtmetrology.omm.simulator (the covariance simulator, Sepahi Boroujeni (2021), §6.2)."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.fitting.features import GaugeLength
from mtmetrology.kinematics.machine import Machine
from mtmetrology.omm.simulator import (
    MeasurementModel,
    covariance_simulator,
    population_covariance,
)
from mtmetrology.uncertainty.guf import guf
from mtmetrology.uncertainty.inputs import InputSet
from mtmetrology.units import to_internal

MACHINE = Machine.load("five-axis-wcbxfzyst")
UM = to_internal(1.0, "µm")
XX = MACHINE.parameter_names.index("E_XX1")


def _one_axis_example(simulator: str, draws: int = 10_000):
    """Eqs. 6-8 to 6-12: φ = 100 mm on X, v = 1 µm², δ = −50 µm/m, σ² = 100 (µm/m)²."""
    readings = np.array([[100.0, 0.0, 100.0, 0.0, 0.0, 0.0]])
    delta = np.zeros(MACHINE.n_params)
    delta[XX] = to_internal(-50.0, "µm/m")
    sigma = np.zeros((MACHINE.n_params, MACHINE.n_params))
    sigma[XX, XX] = to_internal(10.0, "µm/m") ** 2
    v = np.zeros((1, 6, 6))
    v[0, 0, 0] = UM**2
    joint = population_covariance(
        MACHINE,
        readings,
        delta,
        sigma,
        reading_covariance=v,
        simulator=simulator,
        draws=draws,
        seed=12,
    )
    p = MACHINE.n_axes  # index of the first parameter in x
    block = joint[np.ix_([0, p + XX], [0, p + XX])]
    return (readings, delta, joint), block


def test_linear_simulator_reproduces_eq_6_12_exactly():
    """cov [Γ; Δ] = [[2.0 µm², −1.0·10⁻² mm·µm/m], [·, 100 (µm/m)²]], corr = −1/√2."""
    _, c = _one_axis_example("linear")
    mm_um_per_m = to_internal(1.0, "µm/m")  # mm·(µm/m) in mm (the parameter is a ratio)
    # First order about δ: var Γ = v/(1+δ)² ... + φ²σ²; the (1+δ) terms are 10⁻⁴ relative.
    assert c[0, 0] == pytest.approx(2.0 * UM**2, rel=2e-4)
    assert c[0, 1] == pytest.approx(-1.0e-2 * mm_um_per_m, rel=2e-4)
    assert c[1, 1] == pytest.approx(100 * mm_um_per_m**2, rel=1e-12)
    assert c[0, 1] / np.sqrt(c[0, 0] * c[1, 1]) == pytest.approx(-1 / np.sqrt(2), rel=2e-4)


def test_sampled_simulator_reproduces_eq_6_12_within_sampling_error():
    """Q = 4·10⁴ draws: variances to 2.5 % (s.e. √(2/Q) = 0.7 %), correlation to ±0.02."""
    _, c = _one_axis_example("sampled", draws=40_000)
    assert c[0, 0] == pytest.approx(2.0 * UM**2, rel=0.025)
    assert c[1, 1] == pytest.approx(100 * to_internal(1.0, "µm/m") ** 2, rel=0.025)
    assert c[0, 1] / np.sqrt(c[0, 0] * c[1, 1]) == pytest.approx(-1 / np.sqrt(2), abs=0.02)


def test_joint_pdf_gives_u_psi_of_1_um_not_the_printed_2_2_um():
    """§6.2.1 prints u(ψ) = 2.2 µm "using the joint PDF"; propagating ψ = f(Γ, Δ) with the
    eq. 6-12 covariance gives u² = 2.0 + 1.0 − 2·1.0 = 1.0 µm² (first-order cancellation;
    2.2 µm = √5 would add the covariance term instead of subtracting it).  This joint PDF
    is the model of readings compensated with the machine's true parameters of the day;
    a task compensated with a calibration is in tests/omm/test_task_calibration.py."""
    (readings, delta, joint), _ = _one_axis_example("linear")
    n_x = joint.shape[0]
    ux = np.zeros((n_x + 3, n_x + 3))
    ux[:n_x, :n_x] = joint
    names = [f"x{i}" for i in range(n_x + 3)]
    inputs = InputSet.from_covariance(
        names, np.concatenate([readings.ravel(), delta, np.zeros(3)]), ux
    )

    class X:
        unit, output_names = "mm", ("x",)

        @staticmethod
        def value(points):
            return points[..., 0, 0]

    r = guf(MeasurementModel(MACHINE, X(), 1), inputs)
    assert r.standard_uncertainty[0] / UM == pytest.approx(1.0, rel=1e-3)
    assert abs(r.standard_uncertainty[0] / UM - 2.2) > 1.0


def test_sampled_and_linear_simulators_agree_on_a_gauge_task():
    """Table 7-1 readings, 1 µm repeatability, 5-unit calibration u and day-to-day
    variation: the sampled U_x (Q = 2·10⁴ for each of the repeatability and long-term
    parts) against the linearised one, every variance within 5 %."""
    readings = MACHINE.readings_from_customary(
        {
            "X": [-138.5650, -61.2880],
            "Y": [94.6560, 48.3440],
            "Z": [196.2320, 246.8170],
            "B": [-42.0, -64.0],
            "C": [-293.0, -124.0],
        }
    )
    sigma = np.diag((MACHINE.parameter_scales * 5.0) ** 2)
    v = np.zeros((2, 6, 6))
    v[:, :3, :3] = np.eye(3) * UM**2
    args = (MACHINE, readings, np.zeros(13), sigma)
    kw = dict(reading_covariance=v, long_term_covariance=sigma)
    lin = covariance_simulator(*args, **kw)
    smp = covariance_simulator(*args, **kw, simulator="sampled", draws=20_000, seed=3)
    live = np.diag(lin.covariance) > 0
    np.testing.assert_allclose(
        np.diag(smp.covariance)[live], np.diag(lin.covariance)[live], rtol=0.05
    )
    assert np.all(np.diag(smp.covariance)[~live] == 0)  # rotary readings stay commanded
    u = guf(MeasurementModel(MACHINE, GaugeLength(tip_diameter=0.0), 2), lin.input_set())
    w = guf(MeasurementModel(MACHINE, GaugeLength(tip_diameter=0.0), 2), smp.input_set())
    assert w.standard_uncertainty[0] == pytest.approx(u.standard_uncertainty[0], rel=0.05)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(simulator="bootstrap"), "simulator must be one of"),
        (dict(simulator="sampled", draws=10), "needs at least"),
        (dict(calibration_covariance=-np.eye(13) * 1e-6), "not positive semidefinite"),
        (dict(long_term_covariance=-np.eye(13) * 1e-6), "long-term covariance: not positive"),
        (dict(readings=np.zeros((2, 5))), r"shape \(n, 6\)"),
    ],
)
def test_bad_input_is_refused_naming_the_argument(kwargs, message):
    args = dict(
        readings=np.tile([0.0, 0.0, 100.0, 0.0, 0.0, 0.0], (2, 1)),
        parameters=np.zeros(13),
        calibration_covariance=np.eye(13) * 1e-12,
    )
    args.update(kwargs)
    with pytest.raises(InputError, match=message):
        covariance_simulator(MACHINE, **args)
