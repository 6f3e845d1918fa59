"""Compiled kernel running a chain :class:`~mtmetrology.kinematics._program.Program`.

Imported only when the compiled backend is used (numba costs about half a second to
import).  The kernel is compiled once and cached on disk (``cache=True``), so later
processes load it in a fraction of a second.

Loop order: blocks of ``lanes`` trials (their parameters loaded once into the first
registers), then poses (one row of the per-pose table), then instructions, each a short
loop over the trials of the block that the compiler vectorises.  The registers of a
block (a few dozen rows of ``lanes`` doubles) stay in the L1/L2 cache; the output is
written once.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from mtmetrology.kinematics._program import (
    ADD_RR,
    ADD_RS,
    FMA_RR,
    FMA_RS,
    FMS_RR,
    MUL_RR,
    MUL_RS,
    NEG,
    POSITION,
    STORE_NEG,
    STORE_R,
    SUB_RR,
)

#: Trials per block: 128 doubles per register row.
LANES = 128
#: Poses per chunk: positions of a chunk of poses and a block of trials are gathered
#: in a small buffer (POSE_CHUNK × 3 × LANES doubles, 384 kB) and written out
#: trial by trial, so that the output is written sequentially, not 24 bytes at a time.
POSE_CHUNK = 128


@njit(cache=True, nogil=True)
def run(ops, table, theta, n_registers, position, jacobian):  # pragma: no cover - compiled
    """Fill ``position`` (n_trials·n_poses, 3) and ``jacobian`` (same rows, n_jac).

    ops : (n_ops, 5) int64; table : (n_poses, n_columns) per-pose values;
    theta : (n_trials, n_params) error parameters, one row per trial.
    Row ``t·n_poses + i`` of the outputs is trial t at pose i.
    """
    n_trials, n_params = theta.shape
    n_poses = table.shape[0]
    n_ops = ops.shape[0]
    r = np.empty((n_registers, LANES))
    stage = np.empty((POSE_CHUNK, 3, LANES))
    for t0 in range(0, n_trials, LANES):
        n = min(LANES, n_trials - t0)
        for j in range(n_params):
            for k in range(n):
                r[j, k] = theta[t0 + k, j]
        for i0 in range(0, n_poses, POSE_CHUNK):
            n_chunk = min(POSE_CHUNK, n_poses - i0)
            for i in range(i0, i0 + n_chunk):
                s = table[i]
                for o in range(n_ops):
                    code = ops[o, 0]
                    # row views: the compiler vectorises loops over one-dimensional rows
                    rd = r[ops[o, 1]]
                    ra = r[ops[o, 2]]
                    rb = r[ops[o, 3]]
                    c = ops[o, 4]
                    if code == FMA_RS:
                        v = s[c]
                        for k in range(n):
                            rd[k] = ra[k] + rb[k] * v
                    elif code == FMA_RR:
                        rc = r[c]
                        for k in range(n):
                            rd[k] = ra[k] + rb[k] * rc[k]
                    elif code == FMS_RR:
                        rc = r[c]
                        for k in range(n):
                            rd[k] = ra[k] - rb[k] * rc[k]
                    elif code == MUL_RS:
                        v = s[c]
                        for k in range(n):
                            rd[k] = ra[k] * v
                    elif code == ADD_RS:
                        v = s[c]
                        for k in range(n):
                            rd[k] = ra[k] + v
                    elif code == ADD_RR:
                        for k in range(n):
                            rd[k] = ra[k] + rb[k]
                    elif code == SUB_RR:
                        for k in range(n):
                            rd[k] = ra[k] - rb[k]
                    elif code == MUL_RR:
                        for k in range(n):
                            rd[k] = ra[k] * rb[k]
                    elif code == NEG:
                        for k in range(n):
                            rd[k] = -ra[k]
                    elif ops[o, 3] == POSITION:
                        # stores: b selects the output, d is its column
                        out = stage[i - i0, ops[o, 1]]
                        if code == STORE_R:
                            for k in range(n):
                                out[k] = ra[k]
                        elif code == STORE_NEG:
                            for k in range(n):
                                out[k] = -ra[k]
                        else:
                            v = s[c]
                            for k in range(n):
                                out[k] = v
                    else:
                        col = ops[o, 1]
                        first = t0 * n_poses + i
                        if code == STORE_R:
                            for k in range(n):
                                jacobian[first + k * n_poses, col] = ra[k]
                        elif code == STORE_NEG:
                            for k in range(n):
                                jacobian[first + k * n_poses, col] = -ra[k]
                        else:
                            v = s[c]
                            for k in range(n):
                                jacobian[first + k * n_poses, col] = v
            for k in range(n):
                first = (t0 + k) * n_poses + i0
                for i in range(n_chunk):
                    for c in range(3):
                        position[first + i, c] = stage[i, c, k]
