"""Positions of Monte Carlo trials sharing their rotary readings equal the chain's."""

import numpy as np

from mtmetrology.kinematics import Machine


def test_shared_pose_positions_equal_forward_for_13_and_84_parameters():
    """K = 7 trials of n = 5 poses, each trial with its own linear readings, errors and
    tool (the 84-parameter model with reversal senses): equal to Machine.forward on the
    full (K, n) readings to 1e-12 mm."""
    rng = np.random.default_rng(4)
    for model in ("13", "84"):
        m = Machine.load("five-axis-wcbxfzyst", model)
        n, k = 5, 7
        cols = {a: rng.uniform(-50, 50, n) for a in ("X", "Y", "Z")}
        cols |= {"B": rng.uniform(-60, 60, n), "C": rng.uniform(0, 360, n), "S": np.zeros(n)}
        q = m.readings_from_customary(cols)
        lin = np.array([m.axis_names.index(a) for a in m.linear_axes])
        values = q[None, :, lin] + rng.normal(0, 0.01, (k, n, lin.size))
        theta = 30.0 * rng.uniform(-1, 1, (k, m.n_params)) * m.parameter_scales
        senses = np.where(rng.random((n, m.n_axes)) < 0.5, -1.0, 1.0)
        tool = m.tool + rng.normal(0, 0.01, (k, 1, 3))
        got = m.chain.positions_shared_poses(q, lin, values, theta, senses=senses, tool=tool)
        full = np.broadcast_to(q, (k, n, m.n_axes)).copy()
        full[:, :, lin] = values
        ref = m.forward(full, theta[:, None, :], senses=senses, tool=tool)
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
