"""Benchmark: 10⁶ Monte Carlo trials of the GUM H.1 end-gauge model.

    l = l_s + d − l_s·(α_s·δθ + δα·θ)          (JCGM 100:2008, H.1; JCGM 101:2008, 9.5)

Inputs (lengths in nm, temperatures in °C):
    l_s   t_18(50 000 623.6, 25²)                 calibration certificate
    d     t_25.6(215, 9.7²)                       comparator
    α_s   rectangular 11.5e-6 ± √3·1.2e-6 /°C     (u = 1.2e-6)
    θ     normal(−0.1, 0.41²) °C                  (JCGM 101 9.5 splits it and uses an arcsine
                                                   for the cyclic part; a normal is enough here:
                                                   the point is speed)
    δα    rectangular ±1e-6 /°C                   (u = 0.58e-6, GUM H.1.3.5)
    δθ    rectangular ±0.05 °C                    (u = 0.029, GUM H.1.3.6)

Contenders, each min and median of at least 5 repeats in one run:

- ours: ``monte_carlo`` in-process (y, u, probabilistically symmetric and shortest 95 %
  intervals, histogram), and on a warm 2-process pool;
- baseline: the 20-line vectorised numpy script a metrologist would write (draw, evaluate,
  mean, standard deviation, one full sort, both intervals);
- loop: the per-trial Python loop, timed on 10⁴ trials and scaled to 10⁶;
- peer: none — GTC (the GUM Tree Calculator) propagates by the GUF only and has no Monte
  Carlo propagation, so no peer library is timed;
- floor: drawing the 6 × 10⁶ random inputs with numpy's generator, nothing else.

Target (issue 8 §6): ours within 1.3× of the random-draw floor.
Run: ``python bench/bench_mcm.py`` (or ``make bench`` for bench/RESULTS.md).
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from harness import Benchmark, Timing
from mtmetrology.uncertainty.distributions import Normal, Rectangular, StudentT
from mtmetrology.uncertainty.executors import ProcessPoolExecutor
from mtmetrology.uncertainty.inputs import InputQuantity, InputSet
from mtmetrology.uncertainty.mcm import monte_carlo

TRIALS = 1_000_000
LOOP_TRIALS = 10_000
ROUNDS = 9
P = 0.95
HALF_WIDTH_ALPHA = math.sqrt(3.0) * 1.2e-6

INPUTS = InputSet(
    [
        InputQuantity("l_s", StudentT(50_000_623.6, 25.0, 18), "nm"),
        InputQuantity("d", StudentT(215.0, 9.7, 25.6), "nm"),
        InputQuantity(
            "alpha_s", Rectangular(11.5e-6 - HALF_WIDTH_ALPHA, 11.5e-6 + HALF_WIDTH_ALPHA)
        ),
        InputQuantity("theta", Normal(-0.1, 0.41)),
        InputQuantity("dalpha", Rectangular(-1e-6, 1e-6)),
        InputQuantity("dtheta", Rectangular(-0.05, 0.05)),
    ]
)


def end_gauge(x: np.ndarray) -> np.ndarray:
    """GUM H.1 model, vectorised: x (M, 6) -> l (M,) in nm."""
    l_s, d, alpha_s, theta, dalpha, dtheta = x.T  # each (M,)
    return l_s + d - l_s * (alpha_s * dtheta + dalpha * theta)


def draw(rng: np.random.Generator, trials: int) -> tuple[np.ndarray, ...]:
    """The random inputs, drawn the cheapest way numpy offers (the floor)."""
    return (
        rng.standard_t(18, trials),
        rng.standard_t(25.6, trials),
        rng.random(trials),
        rng.standard_normal(trials),
        rng.random(trials),
        rng.random(trials),
    )


def numpy_script(seed: int = 2) -> tuple[float, float, tuple, tuple]:
    """The vectorised numpy baseline: what a careful user writes in 20 lines."""
    rng = np.random.default_rng(seed)
    t18, t256, r1, z, r2, r3 = draw(rng, TRIALS)
    l_s = 50_000_623.6 + 25.0 * t18
    d = 215.0 + 9.7 * t256
    alpha_s = 11.5e-6 + HALF_WIDTH_ALPHA * (2.0 * r1 - 1.0)
    theta = -0.1 + 0.41 * z
    dalpha = 1e-6 * (2.0 * r2 - 1.0)
    dtheta = 0.05 * (2.0 * r3 - 1.0)
    values = np.sort(l_s + d - l_s * (alpha_s * dtheta + dalpha * theta))
    q = round(P * TRIALS)
    r = (TRIALS - q) // 2
    symmetric = (values[r], values[r + q])
    start = int(np.argmin(values[q:] - values[:-q]))
    shortest = (values[start], values[start + q])
    return float(values.mean()), float(values.std(ddof=1)), symmetric, shortest


def per_trial_loop(trials: int, seed: int) -> tuple[float, float]:
    """The obvious implementation: one scalar draw per input and one model call per trial."""
    rng = np.random.default_rng(seed)
    values = []
    for _ in range(trials):
        l_s = 50_000_623.6 + 25.0 * rng.standard_t(18)
        d = 215.0 + 9.7 * rng.standard_t(25.6)
        alpha_s = rng.uniform(11.5e-6 - HALF_WIDTH_ALPHA, 11.5e-6 + HALF_WIDTH_ALPHA)
        theta = rng.normal(-0.1, 0.41)
        dalpha = rng.uniform(-1e-6, 1e-6)
        dtheta = rng.uniform(-0.05, 0.05)
        values.append(l_s + d - l_s * (alpha_s * dtheta + dalpha * theta))
    values.sort()
    mean = sum(values) / trials
    return mean, math.sqrt(sum((v - mean) ** 2 for v in values) / (trials - 1))


def main() -> None:
    bench = Benchmark("mcm", f"GUM H.1 end gauge, {TRIALS:,} Monte Carlo trials, p = {P}")
    result = monte_carlo(end_gauge, INPUTS, trials=TRIALS, seed=1)
    mean, std, symmetric, _ = numpy_script()
    # Same model, independent draws: the two agree within Monte Carlo noise (u/√M = 0.03 nm).
    assert abs(result.output().value - mean) < 0.5 and abs(result.output().u - std) < 0.5
    bench.notes.append(
        f"l = {result.output().value:.1f} nm, u(l) = {result.output().u:.1f} nm "
        f"(GUM H.1.6: 31.7 nm first order), symmetric 95 % interval "
        f"[{result.interval[0, 0]:.1f}, {result.interval[0, 1]:.1f}] nm; numpy script "
        f"[{symmetric[0]:.1f}, {symmetric[1]:.1f}] nm"
    )
    rng = np.random.default_rng(4)
    # Ours, the numpy script and the floor are timed in turn within each round, so that a
    # change of load on a shared machine hits all three alike (their ratios are the point).
    contenders = [
        ("monte_carlo, in-process", "ours",
         lambda: monte_carlo(end_gauge, INPUTS, trials=TRIALS, seed=1)),
        ("vectorised numpy script (one sort)", "baseline", numpy_script),
        ("draw the 6 x 10^6 random inputs", "floor", lambda: draw(rng, TRIALS)),
    ]  # fmt: skip
    times = {label: [] for label, _, _ in contenders}
    cpu = {label: [] for label, _, _ in contenders}
    for round_ in range(1 + ROUNDS):  # round 0 warms up
        for label, _, function in contenders:
            start, start_cpu = time.perf_counter(), time.process_time()
            function()
            if round_:
                times[label].append(time.perf_counter() - start)
                cpu[label].append(time.process_time() - start_cpu)
    for label, kind, _ in contenders:
        bench.timings.append(Timing(label, kind, times[label]))
    # CPU time of this process is not inflated by other processes' load (wall clock is).
    ours_cpu, script_cpu, floor_cpu = (statistics.median(cpu[c[0]]) for c in contenders)
    bench.notes.append(
        f"CPU-time medians (process_time): ours {1e3 * ours_cpu:.0f} ms, numpy script "
        f"{1e3 * script_cpu:.0f} ms, floor {1e3 * floor_cpu:.0f} ms: ours / floor = "
        f"{ours_cpu / floor_cpu:.2f}x"
    )
    with ProcessPoolExecutor(2) as pool:
        bench.time(
            "monte_carlo, warm 2-process pool",
            "ours",
            lambda: monte_carlo(end_gauge, INPUTS, trials=TRIALS, seed=1, executor=pool),
            repeats=5,
        )
    bench.time(
        "per-trial Python loop",
        "loop",
        lambda: per_trial_loop(LOOP_TRIALS, 3),
        repeats=5,
        scale=TRIALS / LOOP_TRIALS,
        note=f"timed on {LOOP_TRIALS:,} trials",
    )
    bench.notes.append("peer: none (GTC has no Monte Carlo propagation)")
    bench.target(
        "monte_carlo, in-process",
        1.3,
        relative_to="draw the 6 x 10^6 random inputs",
        text="issue 8 §6: GUM H.1 Monte Carlo within 1.3x of the random-draw floor",
    )
    bench.report()


if __name__ == "__main__":
    main()
