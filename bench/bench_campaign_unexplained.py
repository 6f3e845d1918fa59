"""Benchmark: cov(e) from K repeated SAMBA campaigns (``mtm samba unexplained``).

Problem (examples/samba): K = 6 campaigns of the 13-parameter test, 111 ball-centre
indications each (34 unknowns per calibration), an unmodelled error e ~ N(0, C) added to
each indication, noise 0.5 µm.

Contenders
----------
ours      ``unexplained_from_campaigns``: the same-test check, K calibrations, the
          between- and within-campaign estimates.
floor     the K calibrations alone (``calibrate`` on each records object): the work the
          estimate cannot do without; ours / floor is the estimator's overhead.
baseline  the estimate alone in plain numpy on the K residual fields (centring, Σ d dᵀ/ν,
          eigenvalue clipping), to show it is negligible.

Target: ours within 1.1× the floor.  Measured (2 cores shared): ours 0.070 s min / 0.071 s
median, floor 0.065 / 0.073 s (0.98×), the estimate alone under 0.1 ms; before the
same-test check was vectorised (a per-indication ``np.allclose``) ours was 1.24× the floor.
Run: ``python bench/bench_campaign_unexplained.py``.
"""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import numpy as np

from harness import Benchmark
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.samba import (
    calibrate,
    load_artefact,
    load_balls,
    read_poses,
    read_records,
    simulate_records,
    unexplained_from_campaigns,
)
from mtmetrology.units import to_internal

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "samba"
NOISE = float(to_internal(0.5, "µm"))
K = 6
C_UM2 = np.array([[45.0, -17.0, 5.0], [-17.0, 66.0, 7.0], [5.0, 7.0, 58.0]])


def campaigns(machine, truth, art, tmp: Path):
    """K records objects of the example test with e ~ N(0, C) moved into the readings."""
    balls = load_balls(EXAMPLES / "balls.yaml").centres()
    programme = read_poses(EXAMPLES / "poses.csv")
    rng = np.random.default_rng(1)
    lin = [machine.axis_names.index(a) for a in machine.linear_axes]
    out = []
    for k in range(K):
        path = tmp / f"c{k}.csv"
        simulate_records(
            machine, truth, balls, programme, art, noise=NOISE, seed=rng.integers(2**31)
        ).write(path)
        rec = read_records(path, machine, art)
        e = rng.multivariate_normal(np.zeros(3), C_UM2 * 1e-6, size=len(rec))
        a = machine.axis_jacobian(rec.readings, truth)[:, :, lin]
        q = rec.readings.copy()
        q[:, lin] += np.linalg.solve(a, e[..., None])[..., 0]
        out.append(dataclasses.replace(rec, readings=q))
    return out


def numpy_estimate(r: np.ndarray, p: int, sigma: float) -> np.ndarray:
    k, n, _ = r.shape
    d = (r - r.mean(axis=0)).reshape(-1, 3)
    raw = d.T @ d / ((k - 1) * (n - p / 3)) - sigma**2 * np.eye(3)
    lam, vec = np.linalg.eigh(raw)
    return (vec * np.maximum(lam, 0.0)) @ vec.T


def main() -> None:
    m = Machine.load("five-axis-wcbxfzyst", "13")
    truth = ParameterSet.load(EXAMPLES / "truth.json", m).vector_for(m)
    art = load_artefact(EXAMPLES / "artefact.yaml")
    recs = campaigns(m, truth, art, Path(tempfile.mkdtemp()))
    bench = Benchmark("campaign_unexplained", f"K = {K} campaigns x 111 indications, 34 unknowns")
    bench.time(
        "unexplained_from_campaigns",
        "ours",
        lambda: unexplained_from_campaigns(m, recs, art, sigma=NOISE),
        repeats=5,
    )
    bench.time(
        f"{K} calibrations alone",
        "floor",
        lambda: [calibrate(m, r, art, sigma=NOISE) for r in recs],
        repeats=5,
    )
    res = unexplained_from_campaigns(m, recs, art, sigma=NOISE)
    bench.time(
        "numpy estimate on the residual fields",
        "baseline",
        lambda: numpy_estimate(res.residuals, res.fitted_parameters, NOISE),
        repeats=20,
    )
    same = numpy_estimate(res.residuals, res.fitted_parameters, NOISE)
    assert np.allclose(same, res.between.covariance, rtol=1e-12, atol=1e-18)
    bench.notes.append("the numpy estimate equals the library's between-campaign Ĉ")
    bench.target("unexplained_from_campaigns", 1.1, relative_to=f"{K} calibrations alone")
    bench.report()


if __name__ == "__main__":
    main()
