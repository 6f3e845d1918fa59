"""Benchmark: cubic drift removal of replicated probing series (Sepahi Boroujeni (2021), §4).

2000 targets × 50 touches (the thesis's ring-gauge tests have 50 replicates per point),
each target with the five series X, Y, Z, N, T: 10 000 cubic fits.

Contenders:
- ours, end to end: :func:`mtmetrology.omm.repeatability.target_statistics` with
  ``drift="cubic"`` (grouping by target and time, N/T projections, the fits, covariances);
- ours, the fits alone: :func:`mtmetrology.omm.drift.detrend_cubic_stack` on (K, 50, 5);
- baseline: the same fits in vectorised numpy, a stacked QR of the Vandermonde matrices
  and r = y − Q Qᵀ y;
- loop: ``numpy.polyfit`` per series (timed on 200 targets, scaled by 10);
- floor: drawing the random readings once.
Target: the fits alone within 3× the QR baseline.
Run: ``python bench/bench_repeatability.py``.
"""

from __future__ import annotations

import numpy as np

from harness import Benchmark
from mtmetrology.omm.drift import detrend_cubic_stack
from mtmetrology.omm.repeatability import target_statistics
from mtmetrology.units import from_internal, to_internal

N_TARGETS, TOUCHES = 2000, 50
UM = to_internal(1.0, "µm")


def draw(rng: np.random.Generator):
    time = np.sort(rng.uniform(0.0, 18000.0, (N_TARGETS, TOUCHES)), axis=1)
    z = time / 18000.0
    drift = sum(rng.uniform(-3, 3, (N_TARGETS, 1, 3)) * UM * z[..., None] ** p for p in (1, 2, 3))
    return time, 28.78 + drift + rng.normal(0.0, 0.5 * UM, (N_TARGETS, TOUCHES, 3))


def qr_residuals(series: np.ndarray, time: np.ndarray) -> np.ndarray:
    low, high = time.min(axis=1, keepdims=True), time.max(axis=1, keepdims=True)
    z = 2.0 * (time - low) / (high - low) - 1.0
    q, _ = np.linalg.qr(z[..., None] ** np.arange(4))  # (K, n, 4)
    return series - q @ (q.transpose(0, 2, 1) @ series)


def polyfit_loop(series: np.ndarray, time: np.ndarray, count: int) -> list:
    out = []
    for g in range(count):
        for j in range(series.shape[2]):
            c = np.polyfit(time[g], series[g, :, j], 3)
            out.append(series[g, :, j] - np.polyval(c, time[g]))
    return out


def main() -> None:
    rng = np.random.default_rng(22)
    time, readings = draw(rng)
    normal = np.tile([0.6, 0.0, 0.8], (N_TARGETS * TOUCHES, 1))
    args = (
        np.repeat([f"t{g}" for g in range(N_TARGETS)], TOUCHES).tolist(),
        np.zeros((N_TARGETS * TOUCHES, 7)),
        readings.reshape(-1, 3),
        normal,
        time.ravel(),
    )
    stats = target_statistics(*args, drift="cubic", discard_first=False)
    series = np.concatenate(
        [readings, (readings * [0.6, 0.0, 0.8]).sum(-1, keepdims=True), readings[..., :1] * 0],
        axis=2,
    )
    ours = detrend_cubic_stack(series, time)
    base = qr_residuals(series - series.mean(axis=1, keepdims=True), time)
    b = Benchmark("omm_drift", f"cubic drift removal, {N_TARGETS} targets × {TOUCHES} touches × 5")
    b.time(
        "ours: target_statistics(drift='cubic')",
        "ours",
        lambda: target_statistics(*args, drift="cubic", discard_first=False),
    )
    b.time("ours: detrend_cubic_stack", "ours", lambda: detrend_cubic_stack(series, time))
    b.time("numpy: stacked QR, y - Q Qᵀ y", "baseline", lambda: qr_residuals(series, time))
    b.time(
        "numpy.polyfit per series",
        "loop",
        lambda: polyfit_loop(series, time, N_TARGETS // 10),
        repeats=5,
        scale=10.0,
    )
    b.time("draw the random readings", "floor", lambda: draw(np.random.default_rng(1)))
    b.target(
        "ours: detrend_cubic_stack",
        3.0,
        relative_to="numpy: stacked QR, y - Q Qᵀ y",
        text="the fits within 3× the QR baseline",
    )
    diff = from_internal(np.abs(ours - base).max(), "µm")
    s = from_internal(np.median(stats.std[:, 0]), "µm")
    b.notes.append(f"max |ours − QR| = {diff:.1e} µm; median detrended σ_X = {s:.3f} µm (0.5)")
    b.report()


if __name__ == "__main__":
    main()
