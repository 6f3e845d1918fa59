"""Benchmark: forward kinematics + parameter Jacobian of the 13-parameter five-axis model.

10^6 (trial, point) pairs, each with its own parameter vector (the Monte Carlo case),
against a straightforward per-point loop of 4×4 homogeneous-matrix products that
evaluates the same model (and whose results are checked against the engine first).

Run: ``python bench/bench_kinematics.py``
"""

from __future__ import annotations

import time

import numpy as np

from mtmetrology.kinematics import Machine

N_PAIRS = 1_000_000
N_LOOP = 2_000


def trans(x, y, z):
    m = np.eye(4)
    m[:3, 3] = (x, y, z)
    return m


def rot(axis, angle):
    c, s = np.cos(angle), np.sin(angle)
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    m = np.eye(4)
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


def small(dx=0.0, dy=0.0, dz=0.0, ea=0.0, eb=0.0, ec=0.0):
    """First-order error HTM (digest 004 §3.5)."""
    return np.array(
        [[1, -ec, eb, dx], [ec, 1, -ea, dy], [-eb, ea, 1, dz], [0, 0, 0, 1]], dtype=float
    )


def generator(k):
    """∂(small)/∂(component k), k = 0..5 for dx, dy, dz, ea, eb, ec."""
    args = [0.0] * 6
    args[k] = 1.0
    return small(*args) - np.eye(4)


# (parameter index, factor position, component) filled in by loop_point
def loop_point(q, th):
    """Tip position and 13-column Jacobian of one (reading, parameter) pair, W -> T."""
    x, y, z, b, c, s = q
    a0b, c0b, x0c, a0c, b0c, b0z, a0y, c0y, xx1, yy1, zz1, y0s, x0s = th
    factors = [
        rot("z", c),  # C table, inverse of Rot_z(-C)
        small(-x0c, 0, 0, -a0c, -b0c, 0),  # first-order inverse of the C location error
        rot("y", b),
        small(0, 0, 0, -a0b, 0, -c0b),
        small(-xx1 * x),  # X error motion, inverse
        trans(x, 0, 0),
        trans(0, 0, 150.0),
        small(0, 0, 0, 0, b0z, 0),
        trans(0, 0, z),
        small(0, 0, zz1 * z),
        small(0, 0, 0, a0y, 0, c0y),
        trans(0, y, 0),
        small(0, yy1 * y),
        small(x0s, y0s),
        rot("z", s),
    ]
    tool = np.array([0.0, 0.0, -150.0, 1.0])
    # parameter -> (factor index, component, derivative factor)
    where = [
        (3, 3, -1),
        (3, 5, -1),
        (1, 0, -1),
        (1, 3, -1),
        (1, 4, -1),
        (7, 4, 1),
        (10, 3, 1),
        (10, 5, 1),
        (4, 0, -x),
        (12, 1, y),
        (9, 2, z),
        (13, 1, 1),
        (13, 0, 1),
    ]
    # prefix[i] = F_0 ... F_{i-1}, suffix[i] = F_{i+1} ... F_n t: two passes of products
    prefix = [np.eye(4)]
    for f in factors:
        prefix.append(prefix[-1] @ f)
    suffix = [tool]
    for f in reversed(factors[1:]):
        suffix.append(f @ suffix[-1])
    suffix.reverse()
    p = (prefix[-1] @ tool)[:3]
    jac = np.empty((3, 13))
    for j, (i, comp, d) in enumerate(where):
        jac[:, j] = d * (prefix[i] @ (generator(comp) @ suffix[i]))[:3]
    return p, jac


def main() -> None:
    m = Machine.load("five-axis-wcbxfzyst")
    rng = np.random.default_rng(0)
    q = np.column_stack(
        [
            rng.uniform(-200, 200, (N_PAIRS, 3)),
            np.deg2rad(rng.uniform(-90, 90, N_PAIRS)),
            np.deg2rad(rng.uniform(0, 360, N_PAIRS)),
            np.deg2rad(rng.choice([0.0, 90.0, 180.0, 270.0], N_PAIRS)),
        ]
    )
    theta = 50.0 * rng.standard_normal((N_PAIRS, 13)) * m.parameter_scales

    # The baseline evaluates the same model: check it before timing it.
    ev = m.evaluate(q[:50], theta[:50], d_params=True)
    for i in range(50):
        p, jac = loop_point(q[i], theta[i])
        assert np.allclose(p, ev.position[i], atol=1e-9), "baseline disagrees (position)"
        assert np.allclose(jac, ev.d_params[i], atol=1e-9), "baseline disagrees (Jacobian)"

    m.evaluate(q[:100_000], theta[:100_000], d_params=True)  # warm-up
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        m.evaluate(q, theta, d_params=True)
        times.append(time.perf_counter() - t0)
    t_engine = min(times)
    t0 = time.perf_counter()
    m.forward(q, theta)
    t_forward = time.perf_counter() - t0

    t0 = time.perf_counter()
    for i in range(N_LOOP):
        loop_point(q[i], theta[i])
    t_loop = (time.perf_counter() - t0) * N_PAIRS / N_LOOP

    print(f"forward + parameter Jacobian, 13-parameter five-axis model, {N_PAIRS:,} pairs")
    print(f"  mtmetrology (vectorised):  {t_engine:8.3f} s   {N_PAIRS / t_engine:12,.0f} pairs/s")
    print(f"  forward only:              {t_forward:8.3f} s   {N_PAIRS / t_forward:12,.0f} pairs/s")
    print(
        f"  per-point 4x4 loop:        {t_loop:8.1f} s   {N_PAIRS / t_loop:12,.0f} pairs/s"
        f"   (timed on {N_LOOP:,} pairs, scaled)"
    )
    print(f"  speed-up: {t_loop / t_engine:,.0f}x   (target >= 100x and < 1 s)")


if __name__ == "__main__":
    main()
