"""A prior on the tool vector as weighted pseudo-observations of a BallCentreProblem:
rows, Jacobians and batched residuals agree, the prior's value is an input, bad priors
are refused."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.identification import BallCentreProblem, ScaleBar
from mtmetrology.kinematics import Machine
from mtmetrology.samba import probing_sequence

SIGMA = 0.0005
PRIOR = (0.002, 0.003, 1.0)  # mm


def _problem(samba_setup, **kw):
    m = Machine.load("five-axis-wcbxfzyst", "13")
    pairs = [(b, c) for b in (-45, 0, 45) for c in (0, 120, 240)]
    ids, q = probing_sequence(m, samba_setup, pairs)
    bar = ScaleBar(("SB1", "SB2"), samba_setup.scale_bar_length, u=0.001)
    return BallCentreProblem(m, q, ids, scale_bars=[bar], estimate_tool=True, sigma=SIGMA, **kw)


def test_prior_rows_are_the_weighted_tool_departure(samba_setup):
    """r_t = (t0 + Δt − t̄)/u_t in the last three rows; ∂r_t/∂Δt = diag(1/u_t)."""
    plain = _problem(samba_setup)
    problem = _problem(samba_setup, tool_prior=PRIOR)
    assert problem.n_rows == plain.n_rows + 3 and problem.n_inputs == plain.n_inputs + 3
    x = problem.initial()
    x[-3:] = [0.01, -0.02, 0.5]
    r, jac = problem.evaluate(x)
    r0, jac0 = plain.evaluate(x)
    np.testing.assert_array_equal(r[:-3], r0)
    np.testing.assert_array_equal(jac[:-3], jac0)
    np.testing.assert_allclose(r[-3:], x[-3:] / np.array(PRIOR), rtol=1e-12)
    np.testing.assert_array_equal(jac[-3:, :-3], 0.0)
    np.testing.assert_allclose(jac[-3:, -3:], np.diag(1 / np.array(PRIOR)), rtol=1e-15)
    np.testing.assert_array_equal(problem.input_estimate()[-3:], problem.machine.tool)
    assert problem.input_names()[-3:] == ["tool prior x", "tool prior y", "tool prior z"]
    np.testing.assert_array_equal(problem.input_uncertainties()[-3:], PRIOR)


def test_batched_residuals_and_input_jacobian_carry_the_prior_value(samba_setup):
    problem = _problem(samba_setup, tool_prior=PRIOR)
    x0, z = problem.initial(), problem.input_estimate()
    # three copies, unknowns and inputs (readings, bar, prior value) all moved by ~1 µm
    moves = 1e-3 * np.random.default_rng(2).standard_normal((3, x0.size + z.size))
    xs, zs = x0 + moves[:, : x0.size], z + moves[:, x0.size :]
    batched = problem.residuals_batch(xs, zs)
    for k in range(3):
        single = problem.with_inputs(zs[k])
        np.testing.assert_array_equal(single.tool_prior_value, zs[k, -3:])
        expected = single.evaluate(xs[k], jacobian=False)[0]
        np.testing.assert_allclose(batched[k], expected, rtol=0, atol=1e-9)
    # the residuals are linear in t̄: one step of each of its components is exact
    jz = problem.input_jacobian(x0)
    h = 1e-3
    steps = np.tile(z, (3, 1))
    steps[:, -3:] += h * np.eye(3)
    moved = problem.residuals_batch(np.tile(x0, (3, 1)), steps)
    base = problem.residuals_batch(x0[None], z[None])[0]
    np.testing.assert_allclose(((moved - base) / h).T, jz[:, -3:], rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(jz[-3:, -3:], np.diag(-1 / np.array(PRIOR)))


@pytest.mark.parametrize(
    ("kw", "field"),
    [
        ({"tool_prior": 0.0}, "positive"),
        ({"tool_prior": -1.0}, "positive"),
        ({"tool_prior": np.nan}, "positive"),
        ({"tool_prior": (1.0, 2.0)}, "three"),
        ({"tool_prior": 1.0, "tool_prior_value": (1.0, 2.0)}, "3 finite"),
        ({"tool_prior_value": (0.0, 0.0, 1.0)}, "needs tool_prior"),
    ],
)
def test_bad_priors_are_refused(samba_setup, kw, field):
    with pytest.raises(InputError, match=field):
        _problem(samba_setup, **kw)


def test_prior_needs_the_tool_among_the_unknowns(samba_setup):
    m = Machine.load("five-axis-wcbxfzyst", "13")
    ids, q = probing_sequence(m, samba_setup, [(0, 0), (45, 90)])
    with pytest.raises(InputError, match="estimate_tool"):
        BallCentreProblem(m, q, ids, sigma=SIGMA, tool_prior=1.0)
