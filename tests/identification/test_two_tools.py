"""Two stylus lengths in one SAMBA test: each tool's vector estimated, and the rank
diagnostics show what the second length buys (Alami Mchichi (2018) Table 4.4)."""

import numpy as np
import pytest

from mtmetrology.design.inputs import default_indexations
from mtmetrology.errors import InputError
from mtmetrology.identification import (
    BallCentreProblem,
    ScaleBar,
    analyse_identifiability,
    levenberg_marquardt,
)
from mtmetrology.kinematics import Machine

IDS = ["1", "2", "3", "4", "SB1", "SB2"]
CENTRES = np.array(
    [
        (-80.0, -40.0, 100.0),
        (80.0, -40.0, 150.0),
        (80.0, 120.0, 75.0),
        (-80.0, 120.0, 175.0),
        (-152.7845, 0.0, 30.0),
        (152.7845, 0.0, 30.0),
    ]
)
BAR = ScaleBar(("SB1", "SB2"), 305.569, 0.001)
TOOLS = np.array([[0.0, 0.0, -150.0], [0.0, 0.0, -100.0]])


@pytest.fixture(scope="module")
def machine():
    """The 13-parameter model plus E_AY1 (roll of the Y carriage, linear in y): with one
    stylus length its effect is a y displacement ∝ y, the Y gain E_YY1's."""
    m = Machine.load("five-axis-wcbxfzyst", "13")
    return m.with_parameters([*m.parameter_names, "E_AY1"])


def _problem(machine, theta, tool_of_row, n_tools, true_tools=TOOLS, sigma=0.001):
    """Readings taken with ``true_tools``; the problem knows the nominal TOOLS."""
    pairs = default_indexations()[::25]
    rows = [(b, B, C, 0.0) for B, C in pairs for b in range(4)]
    rows += [(4, 0.0, 0.0, 0.0), (5, 0.0, 0.0, 0.0), (4, 0.0, 90.0, 0.0), (5, 0.0, 90.0, 0.0)]
    rows += [(4, 0.0, 0.0, s) for s in (90.0, 180.0, 270.0)]
    idx = np.array([r[0] for r in rows])
    cols = {a: np.zeros(len(rows)) for a in machine.axis_names}
    cols["B"], cols["C"], cols["S"] = (np.array([r[k] for r in rows]) for k in (1, 2, 3))
    guess = machine.readings_from_customary(cols)
    tool_index = tool_of_row(len(rows))
    q = machine.inverse(CENTRES[idx], guess, theta, tool=true_tools[tool_index])
    return BallCentreProblem(
        machine,
        q,
        [IDS[i] for i in idx],
        scale_bars=[BAR],
        estimate_tool=True,
        sigma=sigma,
        tools=TOOLS[:n_tools],
        tool_index=tool_index,
    )


def test_a_second_stylus_length_separates_the_confounded_pair(machine):
    """One tool: rank deficient by one, E_AY1 ~ E_YY1 named; the same test with every
    other indication taken with the 100 mm stylus: full rank (two tool vectors estimated)."""
    one = _problem(machine, None, lambda n: np.zeros(n, dtype=int), 1)
    rep1 = analyse_identifiability(one.evaluate(one.initial())[1], one.names)
    assert rep1.rank == len(one.names) - 1
    assert {"E_AY1", "E_YY1"} <= {n for g in rep1.confounded() for n in g}
    two = _problem(machine, None, lambda n: np.arange(n) % 2, 2)
    rep2 = analyse_identifiability(two.evaluate(two.initial())[1], two.names)
    assert rep2.full_rank and len(two.names) == len(one.names) + 3
    assert two.names[-6:] == tuple(f"tool {k} {c}" for k in (1, 2) for c in "xyz")


def test_two_tool_identification_recovers_errors_and_both_tool_vectors(machine):
    """Noise-free readings of a machine with errors of ±50 µm, µrad, µm/m and tools
    offset from their nominal vectors: Gauss-Newton recovers every parameter (E_AY1 too)
    and both tool corrections to 1e-7 of their size."""
    rng = np.random.default_rng(5)
    theta = 50.0 * rng.uniform(-1, 1, machine.n_params) * machine.parameter_scales
    true_tools = TOOLS + np.array([[0.01, -0.02, 0.03], [-0.015, 0.005, 0.02]])
    prob = _problem(machine, theta, lambda n: np.arange(n) % 2, 2, true_tools=true_tools)
    res = levenberg_marquardt(prob)
    est_theta, _, dtool = prob.split(res.estimate)
    np.testing.assert_allclose(
        est_theta / machine.parameter_scales, theta / machine.parameter_scales, atol=1e-5
    )
    np.testing.assert_allclose(TOOLS + dtool, true_tools, atol=1e-7)


def test_tool_index_must_name_a_given_tool(machine):
    q = np.zeros((2, machine.n_axes))
    with pytest.raises(InputError, match=r"tool_index must lie in 0\.\.1"):
        BallCentreProblem(machine, q, ["1", "1"], sigma=0.001, tools=TOOLS, tool_index=[0, 2])
    with pytest.raises(InputError, match="tool\\(s\\) 2 never used"):
        BallCentreProblem(machine, q, ["1", "1"], sigma=0.001, tools=TOOLS, tool_index=[0, 0])


def test_batched_residuals_and_input_jacobian_agree_with_evaluate(machine):
    """The Monte Carlo path (residuals_batch, input_jacobian, with_inputs) sees each
    indication's tool: at a perturbed point the batch equals evaluate, and a finite
    difference in the inputs equals input_jacobian."""
    prob = _problem(machine, None, lambda n: np.arange(n) % 2, 2)
    rng = np.random.default_rng(1)
    x = prob.initial() + 1e-3 * rng.standard_normal(prob.n_unknowns)
    np.testing.assert_allclose(prob.residuals_batch(x[None])[0], prob.evaluate(x)[0], atol=1e-9)
    z = prob.input_estimate()
    dz = np.zeros_like(z)
    dz[7] = 1e-6
    fd = (prob.with_inputs(z + dz).evaluate(x)[0] - prob.evaluate(x)[0]) / 1e-6
    np.testing.assert_allclose(fd, prob.input_jacobian(x)[:, 7], atol=1e-4)
