"""The source's GP (GPML port) and the calibration with the styli as unknowns.

Problems:

- the source's GP demonstration (Salacheep 2016, Appendix 3): 9 points, zero-mean and
  quadratic-mean SE GPs by type-II ML.  Contenders: ours
  (:func:`mtmetrology.cmm.gpml.source_gp_demo`: Cholesky, analytic NLML gradient, BFGS);
  baseline: the same NLML minimised by BFGS on a finite-difference gradient; peer:
  scikit-learn's ``GaussianProcessRegressor`` (ConstantKernel·RBF + WhiteKernel, zero mean
  only, one start); floor: one Cholesky solve of the 9 x 9 system.
- :func:`mtmetrology.cmm.probecal.calibrate_with_probes`: 3 x 3 plate in 4 positions,
  5 styli, 2 qualifications each (180 indications + 10 qualifications; 24 + 51 + 18
  unknowns).  Baseline: ``scipy.optimize.least_squares`` (trf, 2-point finite differences)
  on the same residuals from the same start; floor: drawing the noise of the readings,
  writing the result JSON once.

Run: ``PYTHONPATH=src python bench/bench_cmm_studies.py``.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import numpy as np
import scipy.optimize
from scipy.linalg import cho_factor, cho_solve

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "cmm"))

from cmm_virtual import SIGMA, TRAIN, make_plate, make_positions
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, ConstantKernel, WhiteKernel

from harness import Benchmark
from mtmetrology.cmm.calibrate import model_machine
from mtmetrology.cmm.files import BallPlateRecords, ProbeSet
from mtmetrology.cmm.gpml import negative_log_marginal_likelihood, source_gp_data, source_gp_demo
from mtmetrology.cmm.models import parse_model
from mtmetrology.cmm.probecal import ProbePlateProblem, calibrate_with_probes
from mtmetrology.cmm.simulate import simulate_ballplate
from mtmetrology.io.files import write_json
from mtmetrology.kinematics import Machine

NOMINAL = {"P0": [0, 0, -150], "PX1": [50, 0, -150], "PX2": [-50, 0, -150],
           "PY1": [0, 50, -150], "PY2": [0, -50, -150]}  # fmt: skip


def gp_baseline(x, y):
    """BFGS on a finite-difference gradient of the same NLML (zero and quadratic mean)."""
    out = []
    for mean, x0 in (("zero", [0.0, 0.0, np.log(0.1)]),
                     ("quadratic-x1", [-0.18, 0.78, -0.86, -2.01, -4.08, -4.49])):  # fmt: skip
        out.append(scipy.optimize.minimize(
            lambda h, m=mean: negative_log_marginal_likelihood(h, x, y, m)[0], x0,
            method="BFGS", options={"gtol": 1e-9}))  # fmt: skip
    return out


def gp_sklearn(x, y):
    kern = ConstantKernel(1.0) * RBF(1.0) + WhiteKernel(0.01)
    return GaussianProcessRegressor(kern, normalize_y=False).fit(x, y)


def probe_case():
    base = Machine.load("cmm-moving-bridge")
    rng = np.random.default_rng(5)
    true = {k: np.array(v) + rng.normal(0, 0.003, 3) for k, v in NOMINAL.items()}
    mk = lambda d: ProbeSet(  # noqa: E731
        kind="probe-set", probes=[{"id": k, "offset_mm": list(v)} for k, v in d.items()]
    )
    plate = make_plate(3, 266.0)
    machine, _ = model_machine(base, "seed")
    size = np.where([p.is_rotation for p in machine.parameters], 8e-6, 0.004)
    theta = size * rng.standard_normal(machine.n_params)
    camp = simulate_ballplate(machine, theta, plate, make_positions(*TRAIN), mk(true),
                              sigma=SIGMA, seed=3, perturb_plate=False)  # fmt: skip
    ids = list(NOMINAL) * 2
    t = mk(true).offsets(ids)
    s0 = np.array([600.0, 500.0, 300.0])
    q = machine.inverse(np.tile(s0, (len(ids), 1)), s0 - t, theta, tool=t)
    q = q + SIGMA * rng.standard_normal(q.shape)
    qual = BallPlateRecords(("Q",) * len(ids), ("S",) * len(ids), tuple(ids), q,
                            np.arange(len(ids)) + 2)  # fmt: skip
    return base, camp.records, plate, mk(NOMINAL), qual


def main() -> None:
    x, y = source_gp_data()
    b = Benchmark("cmm-gpml", "the source's GP: 9 points, zero- and quadratic-mean fits")
    ours = source_gp_demo()
    base_res = gp_baseline(x, y)
    b.notes.append(
        "FD-gradient BFGS NLML: "
        f"{base_res[0].fun:.5f} / {base_res[1].fun:.5f} against ours "
        f"{ours.zero_mean.nlml:.5f} / {ours.quadratic_mean.nlml:.5f}"
    )
    b.time("source_gp_demo (zero + quadratic mean, analytic gradient)", "ours", source_gp_demo)
    b.time("BFGS on finite-difference gradient (same NLML)", "baseline",
           lambda: gp_baseline(x, y))  # fmt: skip
    b.time("scikit-learn GPR, zero mean only", "peer", lambda: gp_sklearn(x, y))
    k = np.exp(-np.sum((x[:, None] - x[None]) ** 2, axis=-1)) + 1e-2 * np.eye(9)
    b.time("floor: one 9 x 9 Cholesky solve", "floor",
           lambda: cho_solve(cho_factor(k), y))  # fmt: skip
    b.report()

    base, records, plate, probes, qual = probe_case()
    machine, _ = model_machine(base, parse_model("seed"))
    prob = ProbePlateProblem(machine, records, plate, probes, sigma=SIGMA, qualification=qual)

    def scipy_fd():
        return scipy.optimize.least_squares(
            lambda z: prob.evaluate(z, jacobian=False)[0], prob.initial(), jac="2-point",
            x_scale="jac",
        )  # fmt: skip

    def ours_probes():
        return calibrate_with_probes(base, records, plate, probes, qual, sigma=SIGMA)

    res = ours_probes()
    b = Benchmark("cmm-probecal", "styli as unknowns: 180 indications + 10 qualifications")
    b.time("calibrate_with_probes (24 + 51 + 18 unknowns)", "ours", ours_probes)
    b.time("scipy least_squares 2-point FD, same residuals", "baseline", scipy_fd, repeats=5)
    rng = np.random.default_rng(0)
    b.time("floor: draw 570 normal readings", "floor", lambda: rng.standard_normal(570))
    doc = res.to_dict()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "result.json"
        b.time("floor: write the result JSON once", "floor", lambda: write_json(out, doc))
    b.report()


if __name__ == "__main__":
    main()
