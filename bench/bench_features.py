"""Benchmark: cylinder features for Monte Carlo, and the cost of the minimum-zone features.

1. ``features_cylinder``: 10⁵ least-squares cylinder fits of 25 points each, the Monte
   Carlo load of a bore task (Sepahi Boroujeni (2021), Ch. 6: one feature evaluation per
   trial): stylus-centre points on a Ø 57.575 mm cylinder (a Ø 63.5 mm bore probed with a
   Ø 5.925 mm tip), 24 mm deep, tilted, 1 µm of probing noise.  Contenders, each checked
   against ours before it is timed:

   - ours: :func:`mtmetrology.fitting.batch_cylinders.fit_cylinders` (per-set starting axes, and
     given the nominal axis) and :class:`mtmetrology.fitting.CylinderDiameter`
     ``.value`` (the feature call);
   - baseline: a vectorised numpy Gauss–Newton written here, given the nominal axis of
     the unperturbed task (the easiest start), stacked 5×5 normal equations solved by
     ``numpy.linalg.solve``, all sets at once, until the largest step is at rounding;
   - loop: :func:`mtmetrology.fitting.fit_cylinder` per set, timed on 500 sets and
     extrapolated (labelled);
   - peer: scikit-spatial ``Cylinder.best_fit`` per set, timed on 100 sets and
     extrapolated (skipped with a note when not installed);
   - floor: drawing the random inputs.

2. The minimum-zone features are batched: see ``bench_zones.py``.

Run: ``python bench/bench_features.py``.

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal.
"""

from __future__ import annotations

import numpy as np

from harness import Benchmark
from mtmetrology.fitting import (
    CylinderDiameter,
    fit_cylinder,
    fit_cylinders,
)

SETS = 100_000
LOOP_SETS = 500
PEER_SETS = 100
POINTS = 25
RADIUS = (63.5 - 5.925) / 2.0  # mm, stylus-centre cylinder of the bore
DEPTH = 24.0  # mm
NOISE = 1e-3  # mm
AXIS = np.array([0.05, -0.03, 1.0]) / np.linalg.norm([0.05, -0.03, 1.0])


def _frame(axis: np.ndarray) -> np.ndarray:
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(axis, e1), axis])  # rows e1, e2, axis


def make_sets(n_sets: int, seed: int = 2026) -> np.ndarray:
    """(n_sets, 25, 3) stylus-centre points in a tilted bore, mm."""
    rng = np.random.default_rng(seed)
    theta = rng.uniform(0.0, 2.0 * np.pi, (n_sets, POINTS))
    z = rng.uniform(-DEPTH, 0.0, (n_sets, POINTS))
    local = np.stack([RADIUS * np.cos(theta), RADIUS * np.sin(theta), z], axis=2)
    pts = local @ _frame(AXIS) + np.array([250.0, -120.0, 80.0])
    return pts + NOISE * rng.standard_normal(pts.shape)


def numpy_gauss_newton(points: np.ndarray, axis: np.ndarray, max_iter: int = 50):
    """Vectorised numpy cylinder fits from one nominal axis: Gauss–Newton on stacked 5×5
    normal equations (axis through (u, v, 0) with direction (α, β, 1) in the nominal
    frame), all sets at once.  Returns radii (K,)."""
    k = points.shape[0]
    x = points - points.mean(axis=1, keepdims=True)
    local = x @ _frame(axis).T  # (K, n, 3)
    state = np.zeros((k, 5))
    state[:, 4] = np.hypot(local[..., 0], local[..., 1]).mean(axis=1)
    for _ in range(max_iter):
        u, v, alpha, beta, r = (state[:, i, None] for i in range(5))
        wx, wy, wz = local[..., 0] - u, local[..., 1] - v, local[..., 2]
        s = (wx * alpha + wy * beta + wz) / (1.0 + alpha**2 + beta**2)
        hx, hy, hz = wx - s * alpha, wy - s * beta, wz - s
        rho = np.sqrt(hx**2 + hy**2 + hz**2)
        jac = np.stack([-hx / rho, -hy / rho, -s * hx / rho, -s * hy / rho, -np.ones_like(rho)], 2)
        res = rho - r
        step = np.linalg.solve(
            np.einsum("kni,knj->kij", jac, jac), -np.einsum("kni,kn->ki", jac, res)[..., None]
        )[..., 0]
        state += step
        if np.abs(step).max() <= 1e-13 * RADIUS:
            break
    return state[:, 4]


def cylinder_benchmark() -> None:
    sets = make_sets(SETS)
    ours = fit_cylinders(sets)
    assert ours.success.all(), ours.message
    feature = CylinderDiameter(inner=True, tip_diameter=5.925)
    assert np.abs(feature.value(sets) - (2 * ours.radii + 5.925)).max() < 1e-12
    r = numpy_gauss_newton(sets, fit_cylinder(sets[0]).element.direction)
    assert np.abs(r - ours.radii).max() < 1e-9, "numpy baseline disagrees"
    subset = sets[:LOOP_SETS]
    loop = np.array([fit_cylinder(p).element.radius for p in subset])
    assert np.abs(loop - ours.radii[:LOOP_SETS]).max() < 1e-10, "fit_cylinder disagrees"

    b = Benchmark(
        "features_cylinder",
        f"least-squares cylinder fits (bore task): {SETS:,} sets × {POINTS} points",
    )
    b.time("fit_cylinders (per-set starting axes)", "ours", lambda: fit_cylinders(sets))
    b.time("CylinderDiameter.value", "ours", lambda: feature.value(sets))
    nominal = fit_cylinder(sets[0]).element.direction
    b.time(
        "fit_cylinders (given the nominal axis)",
        "ours",
        lambda: fit_cylinders(sets, direction=nominal),
        note="the baseline's start",
    )
    b.time(
        "vectorised numpy Gauss-Newton (this file)",
        "baseline",
        lambda: numpy_gauss_newton(sets, nominal),
        note="given the nominal axis",
    )
    b.time(
        "fit_cylinder per set",
        "loop",
        lambda: [fit_cylinder(p) for p in subset],
        scale=SETS / LOOP_SETS,
        note=f"{LOOP_SETS:,} sets, extrapolated",
    )
    try:
        from skspatial.objects import Cylinder, Points
    except ImportError:
        b.notes.append("scikit-spatial not installed (pip install '.[bench]'): peer skipped")
    else:
        few = sets[:PEER_SETS]
        fits = [Cylinder.best_fit(Points(p)) for p in few]
        dev = max(
            abs(float(c.radius) - r) for c, r in zip(fits, ours.radii[:PEER_SETS], strict=True)
        )
        b.time(
            "scikit-spatial Cylinder.best_fit per set",
            "peer",
            lambda: [Cylinder.best_fit(Points(p)) for p in few],
            scale=SETS / PEER_SETS,
            note=f"{PEER_SETS} sets, extrapolated; radii differ from ours by up to {dev:.1e} mm",
        )
    rng = np.random.default_rng(7)
    b.time(
        "draw the random inputs",
        "floor",
        lambda: (rng.uniform(size=(SETS, POINTS, 2)), rng.standard_normal((SETS, POINTS, 3))),
    )
    b.target(
        "fit_cylinders (per-set starting axes)",
        1.0 / 10.0,
        relative_to="fit_cylinder per set",
        text="issue 12: vectorised over trials, at least 10x the per-set loop",
    )
    b.notes.append(
        f"mean Gauss-Newton iterations per set: {ours.nit.mean():.2f}; "
        "the machine is shared (2 cores, several users): min and median of 5 repeats"
    )
    b.report()


def main() -> None:
    cylinder_benchmark()


if __name__ == "__main__":
    main()
