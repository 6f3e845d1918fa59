"""Ball-plate calibration of a bridge CMM and its GP error model.

Problem (issue 14): a 25-ball plate (5 x 5, 133 mm pitch) in 4 positions (horizontal, two
vertical, tilted), 5 styli: 500 indications.  Contenders:

- ours: :func:`mtmetrology.cmm.calibrate.calibrate_ballplate` (seed model, 24 error
  parameters + 24 pose + 75 ball unknowns): Gauss-Newton on the analytic Jacobian, full
  covariance, U1/U2/U3 (GUF) — and the full degree-3 model (54 parameters);
- baseline: ``scipy.optimize.least_squares`` (trf, 2-point finite differences) on the same
  residuals from the same start, plus the covariance from its Jacobian;
- GP: :func:`mtmetrology.cmm.gp.fit_gp` (3 components, ML hyper-parameters, 2 pose
  alternations, kinematic mean);
- floor: drawing the noise of the 1500 readings; writing the result JSON once.

Run: ``PYTHONPATH=src python bench/bench_cmm.py``.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.optimize

sys.path.insert(0, str(Path(__file__).resolve().parent))

from harness import Benchmark
from mtmetrology.cmm.calibrate import calibrate_ballplate, model_machine
from mtmetrology.cmm.files import BallPlate, PositionSet, ProbeSet
from mtmetrology.cmm.gp import fit_gp
from mtmetrology.cmm.problem import BallPlateProblem
from mtmetrology.cmm.simulate import simulate_ballplate
from mtmetrology.io.files import write_json
from mtmetrology.kinematics import Machine

SIGMA = 0.0005  # mm


def setup():
    base = Machine.load("cmm-moving-bridge")
    plate = BallPlate(
        kind="ball-plate",
        balls=[
            {"id": f"{5 * j + i:02d}", "x_mm": 133.0 * i, "y_mm": 133.0 * j, "z_mm": 0.0}
            for j in range(5)
            for i in range(5)
        ],
        u_mm=0.0005,
    )
    offsets = [[0, 0, -150], [50, 0, -150], [-50, 0, -150], [0, 50, -150], [0, -50, -150]]
    probes = ProbeSet(
        kind="probe-set", probes=[{"id": f"P{k}", "offset_mm": o} for k, o in enumerate(offsets)]
    )
    ids = [p.id for p in probes.probes]
    positions = PositionSet(
        kind="ballplate-positions",
        positions=[
            {"id": "H", "origin_mm": [330, 230, 150], "rotation_deg": [0, 0, 0], "probes": ids},
            {"id": "VX", "origin_mm": [330, 500, 10], "rotation_deg": [90, 0, 0], "probes": ids},
            {"id": "VY", "origin_mm": [600, 230, 10], "rotation_deg": [90, 0, 90], "probes": ids},
            {"id": "T", "origin_mm": [330, 230, 120], "rotation_deg": [30, 0, 0], "probes": ids},
        ],
    )
    truth, _ = model_machine(base, "full-3")
    rng = np.random.default_rng(1)
    theta = np.where(
        [p.is_rotation for p in truth.parameters],
        rng.normal(0, 10e-6, truth.n_params),
        rng.normal(0, 0.004, truth.n_params),
    )
    camp = simulate_ballplate(truth, theta, plate, positions, probes, sigma=SIGMA, seed=2)
    return base, plate, probes, camp.records


def scipy_fd(problem):
    """The baseline: scipy's trust-region solver with a finite-difference Jacobian."""
    x0 = problem.initial()
    res = scipy.optimize.least_squares(
        lambda x: problem.evaluate(x, jacobian=False)[0], x0, jac="2-point", x_scale="jac"
    )
    j = res.jac
    return res.x, np.linalg.pinv(j.T @ j)


def main() -> None:
    base, plate, probes, records = setup()
    assert len(records) == 500
    seed_machine, _ = model_machine(base, "seed")
    problem = BallPlateProblem(seed_machine, records, plate, probes, sigma=SIGMA)

    ours = calibrate_ballplate(base, records, plate, probes, model="seed", sigma=SIGMA)
    x_fd, _ = scipy_fd(problem)
    diff = np.max(
        np.abs(x_fd[: seed_machine.n_params] - ours.theta) / seed_machine.parameter_scales
    )
    b = Benchmark(
        "cmm", "ball-plate calibration, 25 balls x 4 positions x 5 styli (500 indications)"
    )
    b.notes.append(f"scipy FD solution agrees with ours to {diff:.2g} (µm, µrad) on the 24 errors")
    b.time(
        "calibrate_ballplate seed (24 + 99 unknowns)",
        "ours",
        lambda: calibrate_ballplate(base, records, plate, probes, model="seed", sigma=SIGMA),
    )
    b.time(
        "calibrate_ballplate full-3 (54 + 99 unknowns)",
        "ours",
        lambda: calibrate_ballplate(base, records, plate, probes, model="full-3", sigma=SIGMA),
    )
    b.time("scipy least_squares 2-point FD, seed", "baseline", lambda: scipy_fd(problem))
    b.time(
        "fit_gp (3 components, seed mean, 2 alternations)",
        "ours",
        lambda: fit_gp(base, records, plate, probes, sigma=SIGMA, mean="seed"),
        repeats=5,
        warmup=0,
    )
    rng = np.random.default_rng(0)
    b.time("floor: draw 1500 normal readings", "floor", lambda: rng.standard_normal(1500))
    doc = ours.to_document()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "result.json"
        b.time("floor: write the result JSON once", "floor", lambda: write_json(out, doc))
    for label, call in [
        ("calibrate_ballplate seed", lambda: calibrate_ballplate(
            base, records, plate, probes, model="seed", sigma=SIGMA)),
        ("fit_gp", lambda: fit_gp(base, records, plate, probes, sigma=SIGMA, mean="seed")),
    ]:  # fmt: skip
        cpu = time.process_time()
        call()
        b.notes.append(f"{label}: {time.process_time() - cpu:.3f} s CPU time (one call)")
    b.notes.append(
        f"load average during the run: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"
    )
    b.target("calibrate_ballplate seed (24 + 99 unknowns)", 0.5, text="issue 14: < 0.5 s")
    b.target("fit_gp (3 components, seed mean, 2 alternations)", 10.0, text="issue 14: < 10 s")
    b.report()


if __name__ == "__main__":
    main()
