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

Prints the time and trials per second of ``monte_carlo`` in-process and on a 2-process
pool (cold: including the pool start; warm: pool already running), and the ratio against
a straightforward per-trial Python loop (timed on 10⁴ trials and scaled to 10⁶).
Target: 10⁶ trials in under 1 s on 2 cores. Run: ``python bench/bench_mcm.py``.
"""

from __future__ import annotations

import math
import time

import numpy as np

from mtmetrology.uncertainty.distributions import Normal, Rectangular, StudentT
from mtmetrology.uncertainty.executors import ProcessPoolExecutor
from mtmetrology.uncertainty.inputs import InputQuantity, InputSet
from mtmetrology.uncertainty.mcm import monte_carlo

TRIALS = 1_000_000
LOOP_TRIALS = 10_000
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


def per_trial_loop(trials: int, seed: int) -> tuple[float, float, tuple[float, float]]:
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
    std = math.sqrt(sum((v - mean) ** 2 for v in values) / (trials - 1))
    low = values[int(0.025 * trials)]
    high = values[int(0.975 * trials)]
    return mean, std, (low, high)


def timed(function, *args, **kwargs):
    start = time.perf_counter()
    result = function(*args, **kwargs)
    return result, time.perf_counter() - start


def main() -> None:
    print(f"GUM H.1 end gauge, {TRIALS:,} Monte Carlo trials (p = 0.95)")
    result, in_process = timed(monte_carlo, end_gauge, INPUTS, trials=TRIALS, seed=1)
    summary = result.scalar
    print(
        f"  l = {summary.estimate:.1f} nm, u(l) = {summary.standard_uncertainty:.1f} nm, "
        f"shortest 95 % interval [{summary.interval_shortest[0]:.1f}, "
        f"{summary.interval_shortest[1]:.1f}] nm  (GUM H.1: u_c = 31.7 nm)"
    )
    rows = [("monte_carlo, in-process", in_process)]
    with ProcessPoolExecutor(2) as pool:
        cold_result, cold = timed(
            monte_carlo, end_gauge, INPUTS, trials=TRIALS, seed=1, executor=pool
        )
        _, warm = timed(monte_carlo, end_gauge, INPUTS, trials=TRIALS, seed=1, executor=pool)
    assert np.array_equal(cold_result.estimate, result.estimate), "executors must agree"
    rows += [("monte_carlo, 2 processes (cold)", cold), ("monte_carlo, 2 processes (warm)", warm)]

    (loop_mean, loop_std, _), loop_time = timed(per_trial_loop, LOOP_TRIALS, 2)
    loop_scaled = loop_time * TRIALS / LOOP_TRIALS
    print(
        f"  per-trial loop on {LOOP_TRIALS:,} trials: {loop_time:.3f} s "
        f"(l = {loop_mean:.1f} nm, u = {loop_std:.1f} nm); scaled to {TRIALS:,}: "
        f"{loop_scaled:.1f} s"
    )
    print(f"  {'run':<34}{'time (s)':>10}{'trials/s':>14}{'vs loop':>10}")
    for name, seconds in rows:
        print(
            f"  {name:<34}{seconds:>10.3f}{TRIALS / seconds:>14,.0f}{loop_scaled / seconds:>9.0f}x"
        )
    best = min(seconds for _, seconds in rows)
    print(f"  target 10^6 trials < 1 s: {'met' if best < 1.0 else 'NOT met'} ({best:.3f} s)")


if __name__ == "__main__":
    main()
