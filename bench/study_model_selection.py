"""Study: which model ``mtm cmm calibrate --model auto`` picks, over seeds.

The virtual bridge CMM of ``tests/cmm/test_model_selection.py`` (seed-model errors plus
third-degree straightness; five calibration positions, three styli) is simulated at seeds
3–12.  Each candidate is calibrated on all five positions and judged on two other positions
against the truth (RMS length error of every ball pair, µm).  The table gives each
candidate's held-out error, the choice of the rule of issue 18 (lowest AIC among the
candidates whose robust held-out score is within 1.25x the best), the choice of the former
rule (lowest mean leave-one-position-out RMS), and each choice's held-out error relative to
the best candidate's.  It also times ``cross_validate`` (min and median over the seeds).

Not run by ``make bench`` (a study, not a speed benchmark): ``python
bench/study_model_selection.py`` (about a minute on one core).
"""

from __future__ import annotations

import os
import sys
import time
from pathlib import Path

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "cmm"))
from test_model_selection import (  # noqa: E402
    CALIBRATION,
    CANDIDATES,
    HELD_OUT,
    SIGMA,
    _held_out_rms_um,
    _positions,
    setup,
)

from mtmetrology.cmm import simulate_ballplate  # noqa: E402
from mtmetrology.cmm.calibrate import calibrate_ballplate, cross_validate  # noqa: E402


def main() -> None:
    base, machine, theta, probes, plate = setup.__wrapped__()
    print("seed | " + " | ".join(CANDIDATES) + " | chosen | ratio | lowest mean | ratio")
    times = []
    for seed in range(3, 13):
        cal = simulate_ballplate(
            machine, theta, plate, _positions(CALIBRATION), probes, sigma=SIGMA, seed=seed
        )
        test = simulate_ballplate(
            machine, theta, plate, _positions(HELD_OUT), probes, sigma=SIGMA, seed=seed + 100
        )
        held = {
            c: _held_out_rms_um(
                calibrate_ballplate(base, cal.records, plate, probes, model=c, sigma=SIGMA),
                test,
                probes,
            )
            for c in CANDIDATES
        }
        t0 = time.perf_counter()
        sel = cross_validate(base, cal.records, plate, probes, CANDIDATES, sigma=SIGMA)
        times.append(time.perf_counter() - t0)
        old = min(
            sel["scores"],
            key=lambda s: np.inf if None in s["rms_um"] else np.mean(s["rms_um"]),
        )["model"]
        best = min(held.values())
        print(
            f"{seed} | "
            + " | ".join(f"{held[c]:.3f}" for c in CANDIDATES)
            + f" | {sel['chosen']} | {held[sel['chosen']] / best:.2f} | {old} | "
            f"{held[old] / best:.2f}"
        )
    print(f"cross_validate: min {min(times):.2f} s, median {np.median(times):.2f} s")


if __name__ == "__main__":
    main()
