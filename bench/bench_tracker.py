"""Benchmark: Monte Carlo of a laser-tracker verification and the placement study.

Problem (Aguado et al. (2019), Study 2; issue 21): the XFYZ preset, 21 error functions
(51 coefficients), the paper's 75-point mesh with 3 tool offsets (225 points, 675
readings), the paper's tracker pose; the datum keeps 47 coefficients + 6 pose unknowns.

Contenders
----------
ours      ``tracker.verify``: 10⁴ verifications, each a full identification, batched on the
          chord iteration of ``optimize.chord_batch`` (exact pose, linear-in-θ machine).
baseline  vectorised numpy, one linearised step for all trials (``x = x₀ − J₀⁺ r(x₀)``, no
          convergence check, no statistics): the least any batched solver must do.
loop      a per-trial ``scipy.optimize.least_squares`` ("lm", analytic Jacobian of the
          exact chain) on 20 trials, scaled to 10⁴.
floor     drawing the random inputs of 10⁴ verifications (readings, levels, machine).

Then ``tracker.plan_placement`` with 10⁵ candidate poses.

Targets: verification MC 10⁴ × 225 points under 30 s on 2 cores; placement 10⁵ poses
under 10 s.  Run: ``python bench/bench_tracker.py``.
"""

from __future__ import annotations

import numpy as np
import scipy.optimize

from harness import Benchmark
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.tracker import TrackerNoise, cartesian
from mtmetrology.tracker import PAPER_POSE, calibrate, parse_mesh, plan_placement, simulate, verify
from mtmetrology.tracker.calibrate import corrected_readings, point_covariances
from mtmetrology.tracker.model import TrackerProblem, datum, register, whitening
from mtmetrology.tracker.setup import MachineConditions, measurement_points

TRIALS = 10_000
LOOP_TRIALS = 20
TOOLS = np.array([[0.0, 0.0, -100.0], [100.0, 0.0, -100.0], [0.0, 100.0, -100.0]])


def scipy_problems(machine, truth, mesh, n):
    """Per-trial identification problems built as ``calibrate`` builds them."""
    out = []
    noise, cond = TrackerNoise(), MachineConditions()
    for k in range(n):
        meas = simulate(machine, truth, PAPER_POSE, mesh, TOOLS, seed=100 + k)
        q = corrected_readings(meas.readings, meas.temperatures, cond)
        measured = cartesian(meas.spherical)
        start = register(machine.forward(q, tool=meas.tools), measured)
        kept = datum(machine, meas.readings, meas.tools, start).kept
        ident = machine.with_parameters(kept)
        cov = point_covariances(machine, q, meas.tools, meas.temperatures, measured, start,
                                noise, cond)  # fmt: skip
        out.append(TrackerProblem(ident, q, meas.tools, measured, whitening(cov), start))
    return out


def scipy_solve(problem):
    res = scipy.optimize.least_squares(
        lambda x: problem.evaluate(x, jacobian=False)[0],
        problem.initial(),
        jac=lambda x: problem.evaluate(x)[1],
        method="lm",
        xtol=1e-10,
    )
    return res.x


def main() -> None:
    machine = Machine.load("three-axis-xfyz")
    mesh = parse_mesh("800:1200:100,100:500:100,200:400:100", machine)
    truth = np.random.default_rng(1).normal(0, 10, machine.n_params) * machine.parameter_scales
    bench = Benchmark("tracker_verify", f"{TRIALS:,} verifications of 225 points, 53 unknowns")
    bench.time(
        f"tracker.verify {TRIALS:,}",
        "ours",
        lambda: verify(machine, truth, PAPER_POSE, mesh, TOOLS, trials=TRIALS, seed=1),
        repeats=5,
        warmup=0,
    )
    q, t = measurement_points(mesh, TOOLS)
    kept = datum(machine, q, t, PAPER_POSE).kept
    idx = [machine.parameter_names.index(n) for n in kept]
    ev = machine.evaluate(q, tool=t, d_params=True)
    g = np.concatenate(
        [np.einsum("ji,njk->nik", PAPER_POSE.rotation, ev.d_params[..., idx]),
         PAPER_POSE.jacobian(ev.position)], axis=-1,
    ).reshape(-1, len(idx) + 6)  # fmt: skip
    rng = np.random.default_rng(2)
    r = rng.standard_normal((TRIALS, g.shape[0])) * 0.04

    def one_step():
        pinv = np.linalg.pinv(g)
        return r @ pinv.T

    bench.time("numpy one linearised step (no convergence)", "baseline", one_step, repeats=5)
    problems = scipy_problems(machine, truth, mesh, LOOP_TRIALS)
    bench.time(
        f"scipy least_squares loop ({LOOP_TRIALS} trials, scaled)",
        "loop",
        lambda: [scipy_solve(p) for p in problems],
        repeats=5,
        scale=TRIALS / LOOP_TRIALS,
    )
    bench.time(
        f"draw the inputs ({TRIALS:,} x 225 x 3 readings + machine)",
        "floor",
        lambda: (rng.standard_normal((TRIALS, 225, 3)), rng.standard_normal((TRIALS, 225, 3))),
        repeats=5,
    )
    bench.target(f"tracker.verify {TRIALS:,}", 30.0, text="10^4 verifications under 30 s")
    # the batched and the single identification agree on one trial's data
    single = calibrate(machine, simulate(machine, truth, PAPER_POSE, mesh, TOOLS, seed=100))
    x = scipy_solve(problems[0])
    n = len(single.parameters.names)
    bench.notes.append(
        "scipy and mtm tracker calibrate agree on trial 0 to "
        f"{np.abs(x[:n] - single.parameters.values).max():.2g} (mm or rad, internal units)"
    )
    bench.report()

    place = Benchmark("tracker_placement", "10^5 candidate poses, 75 mesh points")
    place.time(
        "tracker.plan_placement 100,000",
        "ours",
        lambda: plan_placement(machine, mesh, np.zeros((1, 3)), trials=100_000, seed=1),
        repeats=5,
    )
    place.time(
        "draw the inputs (10^5 x 75 x 3 normals)",
        "floor",
        lambda: rng.standard_normal((100_000, 75, 3)),
        repeats=5,
    )
    place.target("tracker.plan_placement 100,000", 10.0, text="10^5 poses under 10 s")
    place.report()


if __name__ == "__main__":
    main()
