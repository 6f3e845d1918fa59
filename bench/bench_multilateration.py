"""Benchmark: sequential multilateration of a three-axis machine, its GUF and its Monte Carlo.

Problem: the ``three-axis-xfyz`` preset with its 21 error functions (51 Legendre
coefficients), 4 LaserTRACER stations × 200 points (800 lengths; the reflector at three
tool offsets in turn, so that every coefficient is observable), noise from the
LaserTRACER NG specification U(k=2) = 0.2 µm + 0.3 µm/m: 67 unknowns (51 + 4 × 4).

Contenders
----------
ours      ``calibrate_multilateration`` (identification by the engine's Gauss–Newton,
          rank diagnostics and the GUF covariance (JᵀJ)⁻¹); ``map_monte_carlo`` with 10⁴
          trials, each re-solved by chord Gauss–Newton steps on the exact lengths, map
          errors at 27 points.
baseline  a linear Monte Carlo in vectorised numpy: one Gauss–Newton step per trial from
          the solution (x = x̂ − J⁺ε/u): the fastest honest re-solve, exact only to first
          order.
loop      a per-trial ``scipy.optimize.least_squares`` (method "lm", analytic Jacobian,
          started at the solution) on 20 trials, scaled to 10⁴.
floor     drawing the random lengths (10⁴ × 800 standard normals).

Targets: identification + GUF < 1 s; Monte Carlo 10⁴ trials < 10 s on 2 cores.
Run: ``python bench/bench_multilateration.py``.
"""

from __future__ import annotations

import numpy as np
import scipy.optimize

from harness import Benchmark
from mtmetrology.kinematics import Machine
from mtmetrology.multilateration.problem import LengthProblem
from mtmetrology.multilateration.workflow import (
    LengthRecord,
    Station,
    calibrate_multilateration,
    map_monte_carlo,
    simulate_lengths,
)
from mtmetrology.units import from_internal

TRIALS = 10_000
LOOP_TRIALS = 20
STATIONS = [
    Station("S1", (750.0, 50.0, 30.0), 100.0),
    Station("S2", (1250.0, 60.0, 40.0), 200.0),
    Station("S3", (760.0, 560.0, 20.0), 300.0),
    Station("S4", (1240.0, 540.0, 50.0), 400.0),
]
TOOLS = np.array([[0.0, 0.0, -100.0], [80.0, 0.0, -150.0], [0.0, 80.0, -150.0]])


def record(machine, theta, rng) -> LengthRecord:
    """200 poses per station, the reflector at the three tools in turn."""
    q = rng.uniform([800, 100, 200], [1200, 500, 400], (200, 3))
    parts = [
        simulate_lengths(machine, theta, STATIONS, q[k::3], TOOLS[k], seed=rng) for k in range(3)
    ]
    return LengthRecord(
        np.vstack([p.readings for p in parts]),
        np.vstack([p.tools for p in parts]),
        tuple(s for p in parts for s in p.stations),
        np.concatenate([p.lengths for p in parts]),
    )


def main() -> None:
    m = Machine.load("three-axis-xfyz")
    rng = np.random.default_rng(0)
    um = np.array([u == "µm" for u in m.parameter_units])
    theta = rng.normal(size=m.n_params) * np.where(um, 3e-3, 5e-6)
    rec = record(m, theta, rng)
    res = calibrate_multilateration(m, rec)
    axes = [np.linspace(lo, hi, 3) for lo, hi in ((800, 1200), (100, 500), (100, 300))]
    points = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)

    problem = LengthProblem(m, rec.readings, rec.tools, rec.stations, rec.lengths)
    x_hat = np.concatenate(
        [
            res.parameters.values,
            np.column_stack(
                [[s.position for s in res.stations], [s.dead_path for s in res.stations]]
            ).ravel(),
        ]
    )
    r_hat, jac = problem.evaluate(x_hat)
    u = problem.sigma()
    q_pts = m.inverse(points, np.zeros((len(points), 3)))
    g_pts = -m.jacobian(q_pts, res.parameters.values).reshape(-1, m.n_params)

    def linear_mc():
        eps = np.random.default_rng(5).standard_normal((TRIALS, u.size))
        x = np.linalg.lstsq(jac, -eps.T, rcond=None)[0].T  # one GN step per trial
        return (x[:, : m.n_params] @ g_pts.T).std(axis=0)

    def scipy_trial(k):
        lengths = rec.lengths + r_hat * u + np.random.default_rng(k).standard_normal(u.size) * u
        trial = LengthProblem(m, rec.readings, rec.tools, rec.stations, lengths)
        trial._u = u
        out = scipy.optimize.least_squares(
            lambda x: trial.evaluate(x, jacobian=False)[0],
            x_hat,
            jac=lambda x: trial.evaluate(x)[1],
            method="lm",
            xtol=1e-12,
        )
        return out.x

    bench = Benchmark(
        "multilateration",
        f"three-axis-xfyz, {m.n_params} coefficients, 4 stations x 200 points "
        f"({rec.lengths.size} lengths), {len(points)} map points, {TRIALS:,} trials",
    )
    bench.time("identification + GUF", "ours", lambda: calibrate_multilateration(m, rec))
    bench.time(
        f"map Monte Carlo {TRIALS:,}",
        "ours",
        lambda: map_monte_carlo(m, rec, res, points, trials=TRIALS, seed=1),
    )
    bench.time(f"linear Monte Carlo {TRIALS:,} (numpy)", "baseline", linear_mc)
    bench.time(
        f"scipy least_squares loop ({LOOP_TRIALS} trials, scaled)",
        "loop",
        lambda: [scipy_trial(k) for k in range(LOOP_TRIALS)],
        scale=TRIALS / LOOP_TRIALS,
    )
    draw = np.random.default_rng(3)
    bench.time(
        f"draw the lengths ({TRIALS:,} x {u.size})",
        "floor",
        lambda: draw.standard_normal((TRIALS, u.size)),
    )
    check = map_monte_carlo(m, rec, res, points, trials=TRIALS, seed=1)
    bench.notes.append(
        f"map u (GUF) up to {from_internal(check.u_guf.max(), 'µm'):.3f} µm; Monte Carlo within "
        f"{100 * check.largest_ratio_deviation:.1f} % of the GUF at the 27 points; "
        f"{check.failed} trials failed"
    )
    bench.target("identification + GUF", 1.0, text="identification and GUF under 1 s")
    bench.target(f"map Monte Carlo {TRIALS:,}", 10.0, text="10^4 trials under 10 s")
    bench.report()


if __name__ == "__main__":
    main()
