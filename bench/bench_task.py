"""Benchmark: GUF of a 25-point sphere-diameter task by the full-covariance method.

The thesis' sphere task (Sepahi Boroujeni (2021), ch. 7): 25 points on a Ø 19.05 mm
sphere probed with a Ø 5.925 mm tip on the five-axis preset, 1 µm repeatability per
reading, a correlated 13×13 long-term parameter covariance and unexplained errors E.
The thesis took 12 s for its GUF.

Contenders:
- ours: :func:`mtmetrology.omm.task.task_uncertainty` (linearised Populations I–IV,
  analytic kinematic and feature Jacobians, the library's GUF engine);
- baseline: the thesis' route in vectorised numpy: the covariance simulator sampled with
  Q = 10⁴ (Populations I–IV through ``Machine.forward`` / ``Machine.inverse``), then the
  GUF engine with central-difference sensitivities;
- floor: writing the result document once.
Target: ours under 0.05 s.
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
from mtmetrology.kinematics.machine import Machine
from mtmetrology.omm.task import _Inputs, task_uncertainty
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
    a = rng.normal(size=(13, 13)) * machine.parameter_scales
    sigma = a @ a.T
    delta = rng.normal(size=13) * machine.parameter_scales * 3
    v = np.zeros((N_POINTS, machine.n_axes, machine.n_axes))
    v[:, :3, :3] = np.eye(3) * UM**2
    cov_e = np.array([[4.5, -1.7, 0.5], [-1.7, 6.6, 0.7], [0.5, 0.7, 5.8]]) * 1e-5
    return machine, readings, delta, sigma, v, cov_e


def sampled_route(machine, readings, delta, sigma, v, cov_e, feature, seed=7):
    """Populations I–IV sampled (Q draws), sample U_x, GUF by central differences."""
    rng = np.random.default_rng(seed)
    n, n_axes = readings.shape
    lin = np.linalg.cholesky(v[:, :3, :3])
    phi = np.repeat(readings[None], Q, axis=0)
    phi[..., :3] += np.einsum("sij,qsj->qsi", lin, rng.standard_normal((Q, n, 3)))  # I
    psi = machine.forward(phi, delta)  # II
    deltas = rng.multivariate_normal(delta, sigma, Q)  # III
    gamma = machine.inverse(psi, np.broadcast_to(readings, phi.shape), deltas[:, None, :])  # IV
    pop = np.hstack([gamma.reshape(Q, -1), deltas])
    size = n * n_axes + 13 + 3 * n
    ux = np.zeros((size, size))
    ux[: n * n_axes + 13, : n * n_axes + 13] = np.cov(pop, rowvar=False)
    ux[n * n_axes + 13 :, n * n_axes + 13 :] = np.kron(np.eye(n), cov_e)
    x = np.concatenate([readings.ravel(), delta, np.zeros(3 * n)])

    def model(xx):
        gam = xx[..., : n * n_axes].reshape(*xx.shape[:-1], n, n_axes)
        dd = xx[..., n * n_axes : n * n_axes + 13]
        pts = machine.forward(gam, dd[..., None, :])
        return feature.value(pts + xx[..., n * n_axes + 13 :].reshape(*xx.shape[:-1], n, 3))

    names = [f"x{i}" for i in range(size)]
    return guf(model, _Inputs(names, [""] * size, x, ux))


def main() -> None:
    machine, readings, delta, sigma, v, cov_e = setup()
    feature = SphereDiameter(tip_diameter=5.925)
    ours = task_uncertainty(
        machine, readings, delta, sigma, feature, reading_covariance=v, unexplained_covariance=cov_e
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


if __name__ == "__main__":
    main()
