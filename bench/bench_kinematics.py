"""Benchmark: batched forward kinematics of the 13-parameter five-axis model (WCBXFZYST).

The Monte Carlo case: 10^5 trials × 100 probing poses, each trial its own parameter
vector (13 parameters, 50 customary units each), the poses shared by the trials, so
``forward(readings (100, 6), params (10^5, 1, 13)) -> (10^5, 100, 3)``.  Contenders, each
checked against the engine before it is timed:

- ours: ``Machine.forward`` (compiled backend) and the same call on the numpy backend;
- baseline: a vectorised numpy chain written here the way a numpy programmer would:
  the nominal 3×3 rotations computed once per pose, each small error transform applied
  to the stacked points as ``v + ε × v + δ`` (``numpy.cross``), each rotation as one
  batched product, in blocks of 1 000 trials;
- loop: a per-point loop of 4×4 homogeneous matrices (timed on 2 000 pairs, scaled);
- floor: writing the (10^5, 100, 3) output once, and drawing the random parameters.

A second problem reports forward + 13-column parameter Jacobian (10^4 trials × 100 poses:
the Jacobian of 10^5 trials would be 3 GB).  Target (issue 8): forward within 3× of its
write floor.  Run: ``python bench/bench_kinematics.py``.
"""

from __future__ import annotations

import numpy as np

from harness import Benchmark, patched
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics import chain as kinematic_chain

TRIALS = 100_000
JACOBIAN_TRIALS = 10_000
POSES = 100
LOOP_PAIRS = 2_000
BLOCK = 1_000  # trials per block of the numpy baseline


# ---------------------------------------------------------------- per-point 4×4 loop
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
    """First-order error HTM (Alami Mchichi (2018), §3.5)."""
    return np.array(
        [[1, -ec, eb, dx], [ec, 1, -ea, dy], [-eb, ea, 1, dz], [0, 0, 0, 1]], dtype=float
    )


def generator(k):
    """∂(small)/∂(component k), k = 0..5 for dx, dy, dz, ea, eb, ec."""
    args = [0.0] * 6
    args[k] = 1.0
    return small(*args) - np.eye(4)


TOOL = np.array([0.0, 0.0, -150.0, 1.0])


def loop_factors(q, th):
    """The W -> T factors of one pair (ISO 230-1 signs: table-side motions flip)."""
    x, y, z, b, c, s = q
    a0b, c0b, x0c, a0c, b0c, b0z, a0y, c0y, xx1, yy1, zz1, y0s, x0s = th
    return [
        rot("z", c),  # C table, inverse of Rot_z(-C)
        small(-x0c, 0, 0, -a0c, -b0c, 0),  # first-order inverse of the C location error
        rot("y", b),
        small(0, 0, 0, -a0b, 0, -c0b),
        small(xx1 * x),  # X error motion: tool relative to workpiece, whichever moves
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


def loop_point(q, th):
    """Tip position and 13-column Jacobian of one (reading, parameter) pair, W -> T."""
    x, y, z = q[:3]
    factors = loop_factors(q, th)
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
        (4, 0, x),
        (12, 1, y),
        (9, 2, z),
        (13, 1, 1),
        (13, 0, 1),
    ]
    prefix = [np.eye(4)]
    for f in factors:
        prefix.append(prefix[-1] @ f)
    suffix = [TOOL]
    for f in reversed(factors[1:]):
        suffix.append(f @ suffix[-1])
    suffix.reverse()
    p = (prefix[-1] @ TOOL)[:3]
    jac = np.empty((3, 13))
    for j, (i, comp, d) in enumerate(where):
        jac[:, j] = d * (prefix[i] @ (generator(comp) @ suffix[i]))[:3]
    return p, jac


# ---------------------------------------------------------------- vectorised numpy chain
def rotations(axis: int, angle: np.ndarray) -> np.ndarray:
    """Stacked rotation matrices (n, 3, 3) about coordinate axis 0/1/2."""
    c, s = np.cos(angle), np.sin(angle)
    i, j = (axis + 1) % 3, (axis + 2) % 3
    r = np.zeros((*angle.shape, 3, 3))
    r[..., axis, axis] = 1.0
    r[..., i, i], r[..., i, j], r[..., j, i], r[..., j, j] = c, -s, s, c
    return r


def rotate(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Per-pose rotations r (P, 3, 3) applied to points v (t, P, 3)."""
    return (v[..., None, :] @ np.swapaxes(r, -1, -2))[..., 0, :]


def small_error(v: np.ndarray, ea=0.0, eb=0.0, ec=0.0, dx=0.0, dy=0.0, dz=0.0) -> np.ndarray:
    """First-order error transform applied to points: v + ε × v + δ."""
    eps = np.stack(np.broadcast_arrays(ea, eb, ec), axis=-1)
    delta = np.stack(np.broadcast_arrays(dx, dy, dz), axis=-1)
    return v + np.cross(eps, v) + delta


def numpy_forward(q: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Vectorised W -> T chain: q (P, 6) shared, theta (T, 13) -> (T, P, 3)."""
    x, y, z, b, c, s = q.T
    rz_c, ry_b, rz_s = rotations(2, c), rotations(1, b), rotations(2, s)  # once per pose
    tool = np.einsum("pij,j->pi", rz_s, TOOL[:3])  # pose-only start of the chain
    out = np.empty((theta.shape[0], q.shape[0], 3))
    for start in range(0, theta.shape[0], BLOCK):
        th = theta[start : start + BLOCK, None, :]  # (t, 1, 13)
        a0b, c0b, x0c, a0c, b0c, b0z, a0y, c0y, xx1, yy1, zz1, y0s, x0s = np.moveaxis(th, -1, 0)
        v = small_error(tool, dx=x0s, dy=y0s)  # (t, P, 3)
        v[..., 1] += yy1 * y + y
        v = small_error(v, ea=a0y, ec=c0y)
        v[..., 2] += zz1 * z + z
        v = small_error(v, eb=b0z)
        v[..., 2] += 150.0
        v[..., 0] += x + xx1 * x
        v = rotate(ry_b, small_error(v, ea=-a0b, ec=-c0b))
        out[start : start + BLOCK] = rotate(rz_c, small_error(v, ea=-a0c, eb=-b0c, dx=-x0c))
    return out


# ---------------------------------------------------------------- problem
def problem(machine: Machine, trials: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    q = np.column_stack(
        [
            rng.uniform(-200, 200, (POSES, 3)),
            np.deg2rad(rng.uniform(-90, 90, POSES)),
            np.deg2rad(rng.uniform(0, 360, POSES)),
            np.deg2rad(rng.choice([0.0, 90.0, 180.0, 270.0], POSES)),
        ]
    )
    theta = 50.0 * rng.standard_normal((trials, 13)) * machine.parameter_scales
    return q, theta


def numpy_backend(function):
    return patched(kinematic_chain, "BACKEND", "numpy", function)


def interpreted(machine: Machine, function):
    """Run with the interpreter kernel instead of the program's generated one."""
    return patched(machine.chain, "generated_min_pairs", 10**18, function)


def time_loop(bench: Benchmark, q: np.ndarray, theta: np.ndarray, pairs: int) -> None:
    bench.time(
        "per-point 4x4 loop",
        "loop",
        lambda: [loop_point(q[i % POSES], theta[i]) for i in range(LOOP_PAIRS)],
        scale=pairs / LOOP_PAIRS,
        note=f"position + Jacobian, {LOOP_PAIRS:,} pairs, scaled",
    )


def check_contenders(m: Machine, q: np.ndarray, theta: np.ndarray) -> None:
    """Every contender evaluates the same model: compare before timing."""
    ev = m.evaluate(q, theta[:20, None, :], d_params=True)
    ref = numpy_backend(lambda: m.evaluate(q, theta[:20, None, :], d_params=True))()
    assert np.array_equal(ev.position, ref.position), "backends disagree (position)"
    many = theta[:20_000, None, :]  # enough pairs for the generated kernel
    assert np.array_equal(m.forward(q, many), numpy_backend(lambda: m.forward(q, many))()), (
        "generated kernel disagrees"
    )
    assert np.allclose(ev.d_params, ref.d_params, rtol=0, atol=1e-12), "backends disagree"
    assert np.allclose(numpy_forward(q, theta[:20]), ev.position, atol=1e-9), "baseline"
    for t in range(3):
        for i in range(10):
            p, jac = loop_point(q[i], theta[t])
            assert np.allclose(p, ev.position[t, i], atol=1e-9), "loop disagrees (position)"
            assert np.allclose(jac, ev.d_params[t, i], atol=1e-9), "loop disagrees (Jacobian)"


def main() -> None:
    m = Machine.load("five-axis-wcbxfzyst")
    q, theta = problem(m, TRIALS)
    check_contenders(m, q, theta)
    pairs = TRIALS * POSES
    th = theta[:, None, :]

    b = Benchmark(
        "kinematics_forward",
        f"forward kinematics, 13-parameter five-axis model: {TRIALS:,} trials (own parameter "
        f"vectors) × {POSES} shared poses = {pairs:,} positions, output {pairs * 24 / 1e6:.0f} MB",
    )
    b.time("Machine.forward (compiled backend)", "ours", lambda: m.forward(q, th))
    b.time(
        "Machine.forward (compiled, interpreter kernel)",
        "ours",
        interpreted(m, lambda: m.forward(q, th)),
        note="one kernel for every program, no per-model compilation",
    )
    b.time(
        "Machine.forward (numpy backend)",
        "ours",
        numpy_backend(lambda: m.forward(q, th)),
        note="MTMETROLOGY_BACKEND=numpy",
    )
    b.time("vectorised numpy chain (this file)", "baseline", lambda: numpy_forward(q, theta))
    time_loop(b, q, theta, pairs)
    b.time("write the output once", "floor", lambda: np.empty((TRIALS, POSES, 3)).fill(0.0))
    b.time(
        "draw the parameters",
        "floor",
        lambda: np.random.default_rng(1).standard_normal((TRIALS, 13)),
    )
    b.target(
        "Machine.forward (compiled backend)",
        3.0,
        relative_to="write the output once",
        text="issue 8: within 3x of the write floor",
    )
    b.notes.append(
        "the machine is shared (2 cores, several users): min and median of 5 repeats; "
        "the floor is measured in the same run"
    )
    b.report()

    qj, thetaj = q, theta[:JACOBIAN_TRIALS, None, :]
    pairs = JACOBIAN_TRIALS * POSES
    j = Benchmark(
        "kinematics_jacobian",
        f"forward + 13-column parameter Jacobian, same model: {JACOBIAN_TRIALS:,} trials × "
        f"{POSES} poses, output {pairs * 42 * 8 / 1e6:.0f} MB",
    )
    j.time(
        "Machine.evaluate(d_params=True) (compiled)",
        "ours",
        lambda: m.evaluate(qj, thetaj, d_params=True),
    )
    j.time(
        "Machine.evaluate(d_params=True) (numpy)",
        "ours",
        numpy_backend(lambda: m.evaluate(qj, thetaj, d_params=True)),
        note="MTMETROLOGY_BACKEND=numpy",
    )
    time_loop(j, q, theta, pairs)
    j.time(
        "write the outputs once",
        "floor",
        lambda: (
            np.empty((JACOBIAN_TRIALS, POSES, 3)).fill(0.0),
            np.empty((JACOBIAN_TRIALS, POSES, 3, 13)).fill(0.0),
        ),
    )
    j.notes.append("no vectorised-numpy Jacobian baseline is written here: see the forward")
    j.report()


if __name__ == "__main__":
    main()
