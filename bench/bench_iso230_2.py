"""Benchmark: ISO 230-2 analysis of 10^4 axis tests (issue 33).

Each test has 11 targets, 5 runs per direction and both approaches: the input is one array
(10^4, 11, 5, 2) of deviations in µm.  Contenders: ours (``positioning.parameters.evaluate``,
the 2014 edition: per-target statistics and the 12 axis parameters of every test); a
vectorised numpy baseline written here another way (sums and sums of squares in one pass,
the parameters from them); a per-test loop of ours on 500 tests, extrapolated; the floor:
drawing the random inputs once, and writing the 12 × 10^4 outputs once.

Run: ``python bench/bench_iso230_2.py``.
"""

from __future__ import annotations

import numpy as np

from harness import Benchmark
from mtmetrology.positioning.parameters import evaluate
from mtmetrology.positioning.simulate import simulate_many

TESTS, TARGETS, RUNS = 10_000, 11, 5
SUBSET = 500


def numpy_baseline(x: np.ndarray) -> dict:
    """The 2014 parameters from one pass of sums and sums of squares over the runs."""
    n = x.shape[-2]
    total = x.sum(axis=-2)
    squares = np.einsum("...jd,...jd->...d", x, x)
    mean = total / n
    s = np.sqrt(np.maximum(squares - n * mean**2, 0.0) / (n - 1))
    up, dn, su, sd = mean[..., 0], mean[..., 1], s[..., 0], s[..., 1]
    b = up - dn
    r_i = np.maximum(2 * (su + sd) + np.abs(b), 4 * np.maximum(su, sd))
    both = mean.reshape(*mean.shape[:-2], -1)
    hi = (mean + 2 * s).reshape(both.shape)
    lo = (mean - 2 * s).reshape(both.shape)
    mid = 0.5 * (up + dn)
    return {
        "B": np.abs(b).max(-1),
        "B_mean": b.mean(-1),
        "R_up": 4 * su.max(-1),
        "R_down": 4 * sd.max(-1),
        "R": r_i.max(-1),
        "E_up": np.ptp(up, -1),
        "E_down": np.ptp(dn, -1),
        "E": np.ptp(both, -1),
        "M": np.ptp(mid, -1),
        "A_up": (up + 2 * su).max(-1) - (up - 2 * su).min(-1),
        "A_down": (dn + 2 * sd).max(-1) - (dn - 2 * sd).min(-1),
        "A": hi.max(-1) - lo.min(-1),
    }


def main() -> None:
    x = simulate_many(TESTS, TARGETS, RUNS, seed=33)
    ours, base = evaluate(x), numpy_baseline(x)
    for key, value in base.items():
        np.testing.assert_allclose(ours[key], value, rtol=0, atol=1e-9)
    out = np.empty((12, TESTS))
    rng = np.random.default_rng(1)
    b = Benchmark(
        "iso230_2_analysis",
        f"ISO 230-2:2014 parameters of {TESTS:,} axis tests ({TARGETS} targets, {RUNS} runs, "
        "both directions)",
    )
    b.time("evaluate (vectorised over tests)", "ours", lambda: evaluate(x))
    b.time("sums and sums of squares (numpy)", "baseline", lambda: numpy_baseline(x))
    b.time(
        "evaluate one test at a time",
        "loop",
        lambda: [evaluate(t) for t in x[:SUBSET]],
        scale=TESTS / SUBSET,
    )
    b.time("draw the random inputs once", "floor", lambda: rng.standard_normal(x.shape))
    b.time("write the 12 x 10^4 outputs once", "floor", lambda: out.fill(0.0))
    b.notes.append("the machine is shared (2 cores, several users): min and median of 5 repeats")
    b.report()


if __name__ == "__main__":
    main()
