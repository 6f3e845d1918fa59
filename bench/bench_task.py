"""Benchmark: GUF and Monte Carlo of a 25-point sphere-diameter task (full-covariance method).

The thesis' sphere task (Sepahi Boroujeni (2021), ch. 7): 25 points on a Ø 19.05 mm
sphere probed with a Ø 5.925 mm tip on the five-axis preset, 1 µm repeatability per
reading, a correlated 13×13 parameter covariance (as the calibration's U_θ and as the
long-term variation Σ_lt) and unexplained errors E.
The thesis took 12 s for its GUF and 1967 s for its adaptive Monte Carlo.

GUF contenders:
- ours: :func:`mtmetrology.omm.task.task_uncertainty` (linearised Populations I–IV,
  analytic kinematic and feature Jacobians, the library's GUF engine);
- baseline: the thesis' route: the covariance simulator sampled with Q = 10⁴
  (``simulator="sampled"``: Populations I–IV through ``Machine.forward`` /
  ``Machine.inverse``), then the GUF engine with central-difference sensitivities;
- floor: writing the result document once.
Target: ours under 0.05 s.

Monte Carlo contenders (10⁵ trials of x ~ N(x, U_x), N = 238 inputs):
- ours: ``task_uncertainty(method="mcm", trials=10**5)``: draws, the kinematic chain over
  all 2.5·10⁶ points at once and the batched sphere fit, chunk by chunk;
- ours, adaptive: the JCGM 101 7.9 procedure (sequences of 10⁴, two significant digits);
- loop: the same model called trial by trial (one ``Machine.forward`` and one
  ``fit_sphere`` per trial), timed on 500 trials and scaled to 10⁵;
- floor: drawing the 10⁵ × 238 correlated normal inputs (the draws and the product by the
  covariance factor), which every Monte Carlo of this model must do.
Target: ours under 5 s (2 cores).
Run: ``python bench/bench_task.py``.
"""

from __future__ import annotations

import os

# 238×238 matrices: BLAS threads only add overhead on a shared 2-core machine (both
# contenders run single-threaded BLAS).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import json
import tempfile
from pathlib import Path

import numpy as np

from harness import Benchmark
from mtmetrology.fitting.features import SphereDiameter
from mtmetrology.fitting.least_squares import fit_sphere
from mtmetrology.kinematics.machine import Machine
from mtmetrology.omm.simulator import MeasurementModel, covariance_simulator
from mtmetrology.omm.task import task_uncertainty
from mtmetrology.uncertainty.guf import guf
from mtmetrology.units import to_internal

N_POINTS = 25
Q = 10_000
UM = to_internal(1.0, "µm")


def setup(seed: int = 2021):
    machine = Machine.load("five-axis-wcbxfzyst")
    rng = np.random.default_rng(seed)
    polar = np.arccos(rng.uniform(0.1, 1.0, N_POINTS))
    azimuth = rng.uniform(0, 2 * np.pi, N_POINTS)
    d = np.column_stack(
        [np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)]
    )
    pts = np.array([0.0, 0.0, 100.0]) + (19.05 + 5.925) / 2 * d
    start = np.zeros((N_POINTS, machine.n_axes))
    start[:, 3] = np.radians(rng.uniform(-60, 60))
    start[:, 4] = np.radians(rng.uniform(-180, 180))
    readings = machine.inverse(pts, start)
    a = machine.parameter_scales[:, None] * rng.normal(size=(13, 13))  # row i in its unit
    sigma = a @ a.T
    delta = rng.normal(size=13) * machine.parameter_scales * 3
    v = np.zeros((N_POINTS, machine.n_axes, machine.n_axes))
    v[:, :3, :3] = np.eye(3) * UM**2
    cov_e = np.array([[4.5, -1.7, 0.5], [-1.7, 6.6, 0.7], [0.5, 0.7, 5.8]]) * 1e-5
    return machine, readings, delta, sigma, v, cov_e


def sampled_route(machine, readings, delta, sigma, v, cov_e, feature, seed=7):
    """Populations I–IV sampled (Q draws), sample U_x, GUF by central differences."""
    inputs = covariance_simulator(
        machine,
        readings,
        delta,
        sigma,
        long_term_covariance=sigma,
        reading_covariance=v,
        unexplained_covariance=cov_e,
        simulator="sampled",
        draws=Q,
        seed=seed,
    )
    return guf(MeasurementModel(machine, feature, len(readings)), inputs.input_set())


def per_trial_loop(machine, inputs, trials, seed=3):
    """The Monte Carlo of the same model, one trial at a time (the thesis' route)."""
    x = inputs.input_set().sample(np.random.default_rng(seed), trials)
    n, n_axes, n_par = inputs.n_points, inputs.n_axes, inputs.n_params
    out = np.empty(trials)
    for t in range(trials):
        gamma = x[t, : n * n_axes].reshape(n, n_axes)
        pts = machine.forward(gamma, x[t, n * n_axes : n * n_axes + n_par])
        pts = pts + x[t, n * n_axes + n_par :].reshape(n, 3)
        out[t] = 2.0 * fit_sphere(pts).element.radius - 5.925
    return out


def main() -> None:
    machine, readings, delta, sigma, v, cov_e = setup()
    feature = SphereDiameter(tip_diameter=5.925)
    ours = task_uncertainty(
        machine,
        readings,
        delta,
        sigma,
        feature,
        long_term_covariance=sigma,
        reading_covariance=v,
        unexplained_covariance=cov_e,
    )
    base = sampled_route(machine, readings, delta, sigma, v, cov_e, feature)
    b = Benchmark("omm_task_guf", "GUF of a 25-point sphere diameter (full-covariance method)")
    b.time(
        "ours: linearised simulator + analytic Jacobians",
        "ours",
        lambda: task_uncertainty(
            machine,
            readings,
            delta,
            sigma,
            feature,
            long_term_covariance=sigma,
            reading_covariance=v,
            unexplained_covariance=cov_e,
        ),
    )
    b.time(
        f"sampled simulator (Q = {Q}) + numeric GUF",
        "baseline",
        lambda: sampled_route(machine, readings, delta, sigma, v, cov_e, feature),
    )
    doc = json.dumps(ours.to_dict(), allow_nan=False)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "out.json"
        b.time("write the result document once", "floor", lambda: path.write_text(doc))
    b.target("ours: linearised simulator + analytic Jacobians", 0.05, text="issue 12: GUF < 0.05 s")
    u_ours = ours.guf.standard_uncertainty[0] / UM
    u_base = base.standard_uncertainty[0] / UM
    b.notes.append(f"u(D): ours {u_ours:.3f} µm, sampled route {u_base:.3f} µm")
    b.report()
    monte_carlo_benchmark(machine, readings, delta, sigma, v, cov_e, feature)


def monte_carlo_benchmark(machine, readings, delta, sigma, v, cov_e, feature) -> None:
    trials = 100_000
    b = Benchmark("omm_task_mcm", "Monte Carlo (10^5 trials) of a 25-point sphere diameter")

    def run(**kw):
        return task_uncertainty(
            machine,
            readings,
            delta,
            sigma,
            feature,
            long_term_covariance=sigma,
            reading_covariance=v,
            unexplained_covariance=cov_e,
            method="mcm",
            seed=5,
            **kw,
        )

    fixed = run(trials=trials)
    adaptive = run()
    b.time("ours: 10^5 trials, vectorised over trials", "ours", lambda: run(trials=trials))
    b.time(
        f"ours: adaptive (JCGM 101 7.9), {adaptive.mcm.trials} trials",
        "ours",
        lambda: run(),
    )
    inputs = fixed.inputs
    subset = 500
    b.time(
        "per-trial loop (forward + fit_sphere per trial)",
        "loop",
        lambda: per_trial_loop(machine, inputs, subset),
        scale=trials / subset,
    )
    input_set = inputs.input_set()
    rng = np.random.default_rng(0)
    b.time("draw the 10^5 × 238 correlated inputs", "floor", lambda: input_set.sample(rng, trials))
    b.target("ours: 10^5 trials, vectorised over trials", 5.0, text="issue 12: MCM < 5 s")
    u_mcm = fixed.mcm.standard_uncertainty[0] / UM
    u_guf = fixed.guf.standard_uncertainty[0] / UM
    b.notes.append(
        f"u(D): Monte Carlo {u_mcm:.3f} µm, GUF {u_guf:.3f} µm; the thesis took 1967 s for "
        "its adaptive Monte Carlo"
    )
    b.report()


if __name__ == "__main__":
    main()
