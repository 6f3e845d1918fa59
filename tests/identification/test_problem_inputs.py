"""The inputs of a BallCentreProblem (readings and bar lengths) for uncertainty propagation:
the batched residuals equal the single ones, and ∂r/∂z matches finite differences."""

from __future__ import annotations

import numpy as np

from mtmetrology.identification import BallCentreProblem, ScaleBar
from mtmetrology.kinematics import Machine
from mtmetrology.samba import probing_sequence

SIGMA = 0.0005


def _problem(samba_setup):
    m = Machine.load("five-axis-wcbxfzyst", "13")
    pairs = [(b, c) for b in (-45, 0, 45) for c in (0, 120, 240)]
    theta = 1e-5 * np.random.default_rng(0).standard_normal(m.n_params)
    ids, q = probing_sequence(m, samba_setup, pairs, params=theta)
    bar = ScaleBar(("SB1", "SB2"), samba_setup.scale_bar_length, u=0.001)
    return BallCentreProblem(m, q, ids, scale_bars=[bar], estimate_tool=True, sigma=SIGMA)


def test_batched_residuals_are_the_single_residuals_of_each_copy(samba_setup):
    problem = _problem(samba_setup)
    rng = np.random.default_rng(1)
    x0 = problem.initial()
    xs = x0 + 1e-6 * rng.standard_normal((4, x0.size))
    zs = problem.input_estimate() + 1e-3 * rng.standard_normal((4, problem.n_inputs))
    batched = problem.residuals_batch(xs, zs)
    for k in range(4):
        n = problem.readings.shape[0]
        q = problem.readings.copy()
        q[:, :3] = zs[k, : 3 * n].reshape(n, 3)
        bar = ScaleBar(("SB1", "SB2"), float(zs[k, -1]), u=0.001)
        single = BallCentreProblem(
            problem.machine,
            q,
            [problem.ball_ids[i] for i in problem._ball_index],
            scale_bars=[bar],
            estimate_tool=True,
            sigma=SIGMA,
        )
        expected = single.evaluate(xs[k], jacobian=False)[0]
        np.testing.assert_allclose(batched[k], expected, rtol=0, atol=1e-9)
        copy = problem.with_inputs(zs[k]).evaluate(xs[k], jacobian=False)[0]
        np.testing.assert_allclose(copy, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        problem.residuals_batch(x0[None])[0],
        problem.evaluate(x0, jacobian=False)[0],
        rtol=0,
        atol=1e-12,
    )


def test_input_jacobian_matches_central_differences(samba_setup):
    problem = _problem(samba_setup)
    x = problem.initial()
    z = problem.input_estimate()
    jac = problem.input_jacobian(x)
    assert (
        jac.shape
        == (problem.n_rows, problem.n_inputs)
        == (problem.n_rows, len(problem.input_names()))
    )
    h = 1e-4
    for j in (0, 4, 17, problem.n_inputs - 1):
        dz = np.zeros_like(z)
        dz[j] = h
        diff = (
            problem.residuals_batch(x[None], (z + dz)[None])
            - problem.residuals_batch(x[None], (z - dz)[None])
        )[0] / (2 * h)
        np.testing.assert_allclose(jac[:, j], diff, rtol=1e-6, atol=1e-6)
