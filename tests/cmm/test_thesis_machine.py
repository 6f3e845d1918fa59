"""The thesis's CMM as a machine file (examples/cmm): axis stacking x -> y -> z, eq. 4.9."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mtmetrology.kinematics import Machine

FILE = Path(__file__).resolve().parents[2] / "examples" / "cmm" / "cmm-salacheep-xyz.yaml"


def _rot(a, b, c):
    """R_z(c) R_y(b) R_x(a) (eqs 4.4–4.7), for arrays of angles."""
    ca, sa, cb, sb, cc, sc = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(c), np.sin(c)
    one, zero = np.ones_like(a), np.zeros_like(a)
    rx = np.stack([[one, zero, zero], [zero, ca, -sa], [zero, sa, ca]]).transpose(2, 0, 1)
    ry = np.stack([[cb, zero, sb], [zero, one, zero], [-sb, zero, cb]]).transpose(2, 0, 1)
    rz = np.stack([[cc, -sc, zero], [sc, cc, zero], [zero, zero, one]]).transpose(2, 0, 1)
    return rz @ ry @ rx


def eq_4_9(q, tool, c, order="xyz"):
    """x* = x_x(x) + R_x(x)[x_y(y) + R_y(y)[x_z(z) + R_z(z) p]] with the named coefficients.

    ``c[name]`` are the Chebyshev coefficients (mm, rad) of the error functions on the
    normalised travel u = (q − 500)/500; ``order`` the stacking (outermost first).
    """
    u = (q - 500.0) / 500.0
    t1 = {a: u[:, i] for i, a in enumerate("XYZ")}
    t2 = {a: 2 * t1[a] ** 2 - 1 for a in "XYZ"}

    def f(name, axis):
        return c.get(name + "1", 0.0) * t1[axis] + c.get(name + "2", 0.0) * t2[axis]

    point = np.broadcast_to(tool, q.shape).copy()
    for axis in reversed(order.upper()):
        i = "XYZ".index(axis)
        delta = np.column_stack([f(f"E_{d}{axis}", axis) for d in "XYZ"])
        rot = _rot(*(f(f"E_{r}{axis}", axis) for r in "ABC"))
        nominal = np.zeros_like(q)
        nominal[:, i] = q[:, i]
        point = nominal + delta + np.einsum("nij,nj->ni", rot, point)
    return point


@pytest.fixture(scope="module")
def machine() -> Machine:
    return Machine.load(FILE)


@pytest.fixture(scope="module")
def case(machine):
    rng = np.random.default_rng(49)
    q = rng.uniform(0, 1000, (50, 3))
    scale = np.array([5e-3 if n[2] in "XYZ" else 2e-5 for n in machine.parameter_names])
    theta = scale * rng.standard_normal(machine.n_params)
    return q, theta, dict(zip(machine.parameter_names, theta, strict=True))


def test_thesis_model_has_24_parameters(machine):
    assert machine.n_params == 24


@pytest.mark.parametrize("tool", [[0, 0, 50.0], [-50.0, 0, 0], [0, 50.0, 0]])
def test_chain_is_eq_4_9_to_second_order(machine, case, tool):
    """First-order effects here are ~20 µm; eq. 4.9 with exact rotations agrees to 2 nm."""
    q, theta, coeffs = case
    ours = machine.forward(q, theta, tool=np.array(tool))
    ref = eq_4_9(q, np.array(tool), coeffs)
    assert np.max(np.abs(ref - q - np.array(tool))) > 5e-3  # the errors are visible
    np.testing.assert_allclose(ours, ref, rtol=0, atol=2e-6)


def test_the_other_stacking_is_not_eq_4_9(machine, case):
    """Y carrying X (the preset's moving bridge) moves the point by the Abbe terms."""
    q, theta, coeffs = case
    ours = machine.forward(q, theta, tool=np.array([0, 0, 50.0]))
    swapped = eq_4_9(q, np.array([0, 0, 50.0]), coeffs, order="yxz")
    assert np.max(np.abs(ours - swapped)) > 1e-3
