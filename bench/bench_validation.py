"""Benchmark: the gauge validation campaign of Sepahi Boroujeni (2021), §6.4 (225 bipoints).

15 side-A × 15 side-B readings of a 500 mm gauge at random B/C on a virtual machine;
every bipoint compensated with its full-covariance GUF interval, eq. 6-16 coverage, and
the ablation without cov(e).

Contenders:
- ours: :func:`mtmetrology.omm.validation.validate_gauge` (one GUF per bipoint; the
  ablation from the budget groups, which add exactly to u²);
- loop: the direct route: two ``task_uncertainty`` calls per bipoint (with and without
  cov(e));
- floor: the compensated lengths alone (no uncertainty): one vectorised forward
  evaluation of the 30 readings and the 225 distances, the least any campaign computes.
Target: ours at most 0.6 of the loop.
Run: ``python bench/bench_validation.py``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np

from harness import Benchmark
from mtmetrology.fitting.features import GaugeLength
from mtmetrology.kinematics.machine import Machine
from mtmetrology.omm.reference import coverage_probability
from mtmetrology.omm.task import task_uncertainty
from mtmetrology.omm.validation import validate_gauge

UM = 1e-3
N_SIDE = 15


def setup(seed: int = 2021):
    m = Machine.load("five-axis-wcbxfzyst")
    rng = np.random.default_rng(seed)
    delta = rng.normal(size=13) * m.parameter_scales * 10
    cov_e = np.array([[4.5, -1.7, 0.5], [-1.7, 6.6, 0.7], [0.5, 0.7, 5.8]]) * 1e-5
    sides = []
    for x in (-250.0, 250.0):
        r = np.zeros((N_SIDE, 6))
        r[:, 3] = np.radians(rng.uniform(-60, 60, N_SIDE))
        r[:, 4] = np.radians(rng.uniform(-180, 180, N_SIDE))
        e = rng.multivariate_normal(np.zeros(3), cov_e, N_SIDE)
        sides.append(m.inverse(np.tile([x, 0.0, 50.0], (N_SIDE, 1)) - e, r, delta))
    v = np.zeros((N_SIDE, 6, 6))
    v[:, :3, :3] = np.eye(3) * (0.5 * UM) ** 2
    u_theta = np.diag((m.parameter_scales * 2.0) ** 2)
    return m, sides, delta, u_theta, v, cov_e


def loop_route(m, sides, delta, u_theta, v, cov_e):
    gauge = GaugeLength(tip_diameter=0.0)
    y, big_u, big_u0 = [], [], []
    for i in range(N_SIDE):
        for j in range(N_SIDE):
            readings = np.vstack([sides[0][i], sides[1][j]])
            vs = np.stack([v[i], v[j]])
            kw = dict(recalibrated=True, reading_covariance=vs)
            g = task_uncertainty(
                m, readings, delta, u_theta, gauge, unexplained_covariance=cov_e, **kw
            ).guf
            g0 = task_uncertainty(m, readings, delta, u_theta, gauge, **kw).guf
            y.append(g.estimate[0])
            big_u.append(g.expanded_uncertainty[0])
            big_u0.append(g0.expanded_uncertainty[0])
    y = np.array(y)
    return (
        coverage_probability(y, np.array(big_u), 500.0, 0.2 * UM).mean(),
        coverage_probability(y, np.array(big_u0), 500.0, 0.2 * UM).mean(),
    )


def main() -> None:
    m, sides, delta, u_theta, v, cov_e = setup()
    bench = Benchmark("validation", "gauge validation campaign, 15 × 15 = 225 bipoints")

    def ours():
        return validate_gauge(
            m, sides[0], sides[1], delta, u_theta, 500.0, 0.2 * UM, tip_diameter=0.0,
            recalibrated=True, reading_covariance_a=v, reading_covariance_b=v,
            unexplained_covariance=cov_e,
        )  # fmt: skip

    def floor():
        qa, qb = m.forward(sides[0], delta), m.forward(sides[1], delta)
        return np.linalg.norm(qb[None, :, :] - qa[:, None, :], axis=-1)

    r = ours()
    loop = loop_route(m, sides, delta, u_theta, v, cov_e)
    assert np.isclose(r.mean_coverage, loop[0]) and np.isclose(r.mean_coverage_without_e, loop[1])
    bench.time("ours: validate_gauge", "ours", ours)
    bench.time(
        "loop: two task_uncertainty per bipoint",
        "loop",
        lambda: loop_route(m, sides, delta, u_theta, v, cov_e),
    )
    bench.time("floor: vectorised lengths, no uncertainty", "floor", floor)
    bench.target(
        "ours: validate_gauge",
        0.6,
        relative_to="loop: two task_uncertainty per bipoint",
        text="the ablation from the budget groups",
    )
    bench.notes.append(
        f"coverage with cov(e) {r.mean_coverage:.3f}, without {r.mean_coverage_without_e:.3f}"
    )
    bench.report()


if __name__ == "__main__":
    main()
