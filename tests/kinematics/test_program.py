"""Tests for mtmetrology.kinematics._program (the chain as a straight-line program).

A reference interpreter written here in numpy from the instruction table runs the
compiled (fused, pruned, register-allocated) program; it must give what the same Python
arithmetic gives on floats.
"""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.kinematics import _program as pr
from mtmetrology.kinematics import _sparse3 as s3
from mtmetrology.kinematics._program import Program


def _run(ops, table, theta, n_registers):
    """Reference interpreter: registers (n_registers, n_trials, n_poses); stores by
    (output, column)."""
    n_trials, n_params = theta.shape
    r = np.zeros((n_registers, n_trials, table.shape[0]))
    r[:n_params] = theta.T[:, :, None]
    s = table.T  # column c -> (n_poses,)
    out = {}
    for code, d, a, b, c in ops.tolist():
        if code == pr.ADD_RR:
            r[d] = r[a] + r[b]
        elif code == pr.SUB_RR:
            r[d] = r[a] - r[b]
        elif code == pr.MUL_RR:
            r[d] = r[a] * r[b]
        elif code == pr.ADD_RS:
            r[d] = r[a] + s[c]
        elif code == pr.MUL_RS:
            r[d] = r[a] * s[c]
        elif code == pr.NEG:
            r[d] = -r[a]
        elif code == pr.FMA_RS:
            r[d] = r[a] + r[b] * s[c]
        elif code == pr.FMA_RR:
            r[d] = r[a] + r[b] * r[c]
        elif code == pr.FMS_RR:
            r[d] = r[a] - r[b] * r[c]
        elif code == pr.STORE_R:
            out[b, d] = r[a].copy()
        elif code == pr.STORE_NEG:
            out[b, d] = -r[a]
        else:
            assert code == pr.STORE_S
            out[b, d] = np.broadcast_to(s[c], r[0].shape).copy()
    return out


def _expressions(x, y, z, s, t):
    """Products, negations and sums of every kind the fusion pass rewrites
    (``0.0 - x`` records −x, so ``-(0.0 - x)`` is a double negation)."""
    return [
        -(x * s - (-(y * t))) + x * y,
        z - y * z + (-(0.0 - x)) - x * 2.5,
        (x + 0.0) * 1.0 + (-1.0) * y + 3.0 - t * z,
        -(z * s),
        x - (-y),
        -(x * y),
    ]


@pytest.mark.parametrize("seed", [0, 1])
def test_compiled_program_computes_the_recorded_arithmetic(seed):
    rng = np.random.default_rng(seed)
    n_poses, n_trials = 5, 4
    s, t = rng.normal(size=n_poses), rng.normal(size=n_poses)
    prog = Program(n_poses=n_poses, n_inputs=3)
    for column, value in enumerate(_expressions(*prog.inputs(), s, t)):
        prog.store(pr.JACOBIAN if column % 2 else pr.POSITION, column, value)
    prog.store(pr.POSITION, 9, s3.ONE)
    ops, n_registers = prog.compile()
    theta = rng.normal(size=(n_trials, 3))
    got = _run(ops, prog.table(), theta, n_registers)
    x, y, z = (theta[:, j, None] for j in range(3))
    for column, expected in enumerate(_expressions(x, y, z, s, t)):
        output = pr.JACOBIAN if column % 2 else pr.POSITION
        expected = np.broadcast_to(expected, (n_trials, n_poses))
        np.testing.assert_allclose(got[output, column], expected, rtol=1e-13, atol=1e-14)
    np.testing.assert_array_equal(got[pr.POSITION, 9], 1.0)


def test_fusion_leaves_fewer_instructions_and_registers_stay_in_range():
    prog = Program(n_poses=3, n_inputs=3)
    s = np.arange(3.0)
    for column, value in enumerate(_expressions(*prog.inputs(), s, s + 1)):
        prog.store(pr.POSITION, column, value)
    recorded = len(prog.instructions)
    ops, n_registers = prog.compile()
    assert len(ops) < recorded
    for code, d, *_ in ops.tolist():
        if code not in (pr.STORE_R, pr.STORE_NEG, pr.STORE_S):
            assert 3 <= d < n_registers  # inputs are never overwritten
    assert n_registers < 3 + recorded


def test_columns_are_shared_by_equal_constants_and_by_the_same_array():
    prog = Program(n_poses=2, n_inputs=1)
    a = np.array([1.0, 2.0])
    assert prog.column(2.0) == prog.column(np.float64(2.0)) == prog.column(np.array(2.0))
    assert prog.column(a) == prog.column(a)
    assert prog.column(a.copy()) != prog.column(a)
    table = prog.table()
    assert table.shape == (2, 3)
    np.testing.assert_array_equal(table[:, prog.column(a)], a)
    np.testing.assert_array_equal(table[:, prog.column(2.0)], 2.0)


def test_identities_record_no_instruction():
    prog = Program(n_poses=2, n_inputs=1)
    (x,) = prog.inputs()
    assert (x + 0.0) is x and (x * 1.0) is x and (0.0 + x) is x
    assert prog.instructions == []
    neg = x * -1.0
    assert prog.instructions == [[pr.NEG, neg.index, 0, 0, 0]]


def test_program_fuses_products_and_reuses_registers():
    """x + y·s and x − y·z become one instruction; dead values are dropped; no
    destination overlaps an operand of its own instruction."""
    from mtmetrology.kinematics import _program as pr

    prog = Program(n_poses=4, n_inputs=2)
    x, y = prog.inputs()
    s = np.arange(4.0)
    unused = x * y  # never stored
    del unused
    value = (x + y * s) - (x * y)
    prog.store(pr.POSITION, 0, -value)
    ops, n_registers = prog.compile()
    assert [int(op[0]) for op in ops] == [pr.FMA_RS, pr.FMS_RR, pr.STORE_NEG]
    for op in ops[:-1]:
        assert op[1] not in op[2:4]
    assert n_registers == 4
