"""Benchmark: 10⁵ least-squares sphere fits of 25 points each, batched.

The data mimic the thesis' sphere task (digest 000 §3.12, §4.5): 25 stylus-centre points
on the upper hemisphere of a Ø 19.05 mm precision sphere probed with an effective tip
Ø 5.925 mm (fit radius 12.49 mm), with 1 µm of probing noise, one set per Monte Carlo
trial.

Prints the time of :func:`mtmetrology.fitting.batch.fit_spheres` on all 10⁵ sets and the
ratio against
- a loop of ``scipy.optimize.least_squares`` (Levenberg–Marquardt, analytic Jacobian,
  started from the centroid and mean distance), timed on 10³ sets and scaled to 10⁵;
- a loop of scikit-spatial's ``Sphere.best_fit`` (optional bench extra; skipped with a
  note when not installed), timed on 10³ sets and scaled.
Each figure is the best of 3 runs.  It also prints how far the fits agree.
Target: at least 50× the scipy loop.
Run: ``python bench/bench_fitting.py``.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.optimize import least_squares

from mtmetrology.fitting.batch import fit_spheres

SETS = 100_000
LOOP_SETS = 1_000
POINTS = 25
RADIUS = (19.05 + 5.925) / 2.0  # mm, stylus-centre sphere
NOISE = 1e-3  # mm
REPEATS = 3


def make_sets(n_sets: int, seed: int = 2026) -> np.ndarray:
    """(n_sets, 25, 3) stylus-centre points on the upper hemisphere, mm."""
    rng = np.random.default_rng(seed)
    polar = np.arccos(rng.uniform(0.0, 1.0, (n_sets, POINTS)))
    azimuth = rng.uniform(0.0, 2.0 * np.pi, (n_sets, POINTS))
    unit = np.stack(
        [np.sin(polar) * np.cos(azimuth), np.sin(polar) * np.sin(azimuth), np.cos(polar)], axis=2
    )
    centre = np.array([250.0, -120.0, 80.0])
    return centre + RADIUS * unit + NOISE * rng.standard_normal((n_sets, POINTS, 3))


def scipy_fit(points: np.ndarray) -> np.ndarray:
    """One sphere by scipy.optimize.least_squares (the obvious implementation)."""

    def residuals(theta: np.ndarray) -> np.ndarray:
        return np.linalg.norm(points - theta[:3], axis=1) - theta[3]

    def jacobian(theta: np.ndarray) -> np.ndarray:
        v = points - theta[:3]
        u = v / np.linalg.norm(v, axis=1)[:, None]
        return np.column_stack([-u, -np.ones(len(points))])

    centroid = points.mean(axis=0)
    start = np.append(centroid, np.linalg.norm(points - centroid, axis=1).mean())
    sol = least_squares(residuals, start, jac=jacobian, method="lm", xtol=1e-15, ftol=1e-15)
    return sol.x


def main() -> None:
    sets = make_sets(SETS)
    fit_spheres(sets[:100])  # warm-up (imports, first-call overheads)
    # Best of 3 runs for both sides (the machine is shared; the minimum is the least
    # disturbed figure, as timeit recommends).
    t_batch = np.inf
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        batch = fit_spheres(sets)
        t_batch = min(t_batch, time.perf_counter() - t0)
    print(f"batched fit_spheres: {SETS:,} sets x {POINTS} points in {t_batch:.2f} s")
    print(f"  {SETS / t_batch:,.0f} fits/s; {batch.message}")

    t_scipy = np.inf
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        reference = np.array([scipy_fit(p) for p in sets[:LOOP_SETS]])
        t_scipy = min(t_scipy, (time.perf_counter() - t0) * SETS / LOOP_SETS)
    dev = np.abs(reference[:, :3] - batch.centres[:LOOP_SETS]).max()
    print(
        f"scipy.optimize.least_squares loop: {t_scipy:.1f} s for {SETS:,} sets "
        f"(timed on {LOOP_SETS:,}); ratio {t_scipy / t_batch:.0f}x (target >= 50x); "
        f"max centre difference {dev:.1e} mm"
    )

    try:
        from skspatial.objects import Points, Sphere
    except ImportError:
        print("scikit-spatial not installed (pip install '.[bench]'): comparison skipped")
        return
    t_sk = np.inf
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        spheres = [Sphere.best_fit(Points(p)) for p in sets[:LOOP_SETS]]
        t_sk = min(t_sk, (time.perf_counter() - t0) * SETS / LOOP_SETS)
    dev = max(
        float(np.abs(np.asarray(s.point) - c).max())
        for s, c in zip(spheres, batch.centres[:LOOP_SETS], strict=True)
    )
    print(
        f"scikit-spatial Sphere.best_fit loop: {t_sk:.1f} s for {SETS:,} sets "
        f"(timed on {LOOP_SETS:,}); ratio {t_sk / t_batch:.0f}x; "
        f"max centre difference {dev:.1e} mm (its fit is the algebraic Kåsa fit, not orthogonal)"
    )


if __name__ == "__main__":
    main()
