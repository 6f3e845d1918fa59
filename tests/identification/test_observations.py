"""Ball-centre observations: residuals, Jacobian, start, counts and refusals, against
quantities computed here from the machine's forward model."""

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.identification import BallCentreProblem, ScaleBar
from mtmetrology.identification.observations import senses_from_sequence
from mtmetrology.kinematics import Machine
from mtmetrology.samba import probing_sequence


def test_senses_follow_the_last_move_of_each_axis():
    q = np.array(
        [
            [0.0, 5.0],
            [1.0, 5.0],  # axis 0 moves +, axis 1 still
            [1.0, 3.0],  # axis 1 moves -
            [0.5, 3.0],  # axis 0 moves -
            [0.5, 3.0],  # nothing moves: senses kept
            [2.0, 4.0],
        ]
    )
    expected = [[1, 1], [1, 1], [1, -1], [-1, -1], [-1, -1], [1, 1]]
    np.testing.assert_array_equal(senses_from_sequence(q), expected)
    start_minus = senses_from_sequence(q, initial=-1.0)
    np.testing.assert_array_equal(start_minus[0], [-1, -1])
    np.testing.assert_array_equal(start_minus[1], [1, -1])


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"ends": ("a", "b"), "length": 0.0, "u": 0.001}, "length"),
        ({"ends": ("a", "b"), "length": np.inf, "u": 0.001}, "length"),
        ({"ends": ("a", "b"), "length": 300.0, "u": 0.0}, "uncertainty u"),
        ({"ends": ("a", "b"), "length": 300.0, "u": np.nan}, "uncertainty u"),
        ({"ends": ("a", "a"), "length": 300.0, "u": 0.001}, "two different balls"),
    ],
)
def test_scale_bar_refuses_bad_values(kwargs, field):
    with pytest.raises(InputError, match=field):
        ScaleBar(**kwargs)


@pytest.fixture(scope="module")
def problem_data(samba_setup):
    m = Machine.load("five-axis-wcbxfzyst")
    pairs = [(b, c) for b in (-60.0, 0.0, 60.0) for c in (0.0, 120.0, 240.0)]
    ids, q = probing_sequence(m, samba_setup, pairs)
    bar = ScaleBar(("SB1", "SB2"), samba_setup.scale_bar_length, 0.0012)
    return m, ids, q, bar


def test_refusals_name_what_is_wrong(problem_data):
    m, ids, q, _ = problem_data
    with pytest.raises(InputError, match=r"readings must be \(n, 6\) for axes XYZBCS"):
        BallCentreProblem(m, q[:, :5], ids, sigma=0.001)
    with pytest.raises(InputError, match=f"{len(ids) - 1} ball ids for {len(ids)} indications"):
        BallCentreProblem(m, q, ids[1:], sigma=0.001)
    with pytest.raises(InputError, match="sigma must be positive"):
        BallCentreProblem(m, q, ids, sigma=0.0)
    with pytest.raises(InputError, match="'SB9' is not among the probed balls"):
        BallCentreProblem(m, q, ids, sigma=0.001, scale_bars=[ScaleBar(("1", "SB9"), 10, 1)])


def test_unknowns_rows_and_rounding(problem_data):
    m, ids, q, bar = problem_data
    p = BallCentreProblem(m, q, ids, sigma=0.002, scale_bars=[bar], estimate_tool=True)
    balls = list(dict.fromkeys(ids))
    assert p.ball_ids == tuple(balls)
    assert p.names == (
        *m.parameter_names,
        *[f"ball {b} {c}" for b in balls for c in "xyz"],
        "tool x",
        "tool y",
        "tool z",
    )
    assert p.n_unknowns == m.n_params + 3 * len(balls) + 3
    assert p.n_rows == 3 * len(ids) + 1
    assert p.residual_rounding == pytest.approx(np.finfo(float).eps * np.abs(q).max() / 0.002)
    small = BallCentreProblem(m, np.zeros((1, 6)), ["1"], sigma=0.5)
    assert small.residual_rounding == pytest.approx(np.finfo(float).eps / 0.5)


def test_start_puts_each_ball_at_the_mean_of_its_predicted_positions(problem_data):
    m, ids, q, _ = problem_data
    p = BallCentreProblem(m, q, ids, sigma=0.001, estimate_tool=True)
    theta = 30.0 * m.parameter_scales
    x0 = p.initial(theta)
    positions = m.forward(q, theta)
    np.testing.assert_array_equal(x0[: m.n_params], theta)
    for k, b in enumerate(p.ball_ids):
        mine = positions[[i for i, name in enumerate(ids) if name == b]].mean(axis=0)
        np.testing.assert_allclose(x0[m.n_params + 3 * k : m.n_params + 3 * k + 3], mine)
    np.testing.assert_array_equal(x0[-3:], 0.0)
    assert x0.size == p.n_unknowns
    theta_back, centres, dtool = p.split(x0)
    np.testing.assert_array_equal(theta_back, theta)
    assert centres.shape == (len(p.ball_ids), 3) and dtool.shape == (3,)
    np.testing.assert_array_equal(BallCentreProblem(m, q, ids, sigma=1.0).initial()[:13], 0.0)


def test_residuals_and_jacobian(problem_data):
    """Residuals written out here; the Jacobian against central differences."""
    m, ids, q, bar = problem_data
    sigma = 0.002
    p = BallCentreProblem(m, q, ids, sigma=sigma, scale_bars=[bar], estimate_tool=True)
    rng = np.random.default_rng(9)
    x = p.initial() + 1e-3 * rng.standard_normal(p.n_unknowns)
    theta, centres, dtool = p.split(x)
    r, jac = p.evaluate(x)
    pos = m.forward(q, theta, tool=m.tool + dtool)
    index = [p.ball_ids.index(b) for b in ids]
    np.testing.assert_allclose(r[:-1], ((pos - centres[index]) / sigma).ravel(), atol=1e-9)
    a, b = p.ball_ids.index("SB1"), p.ball_ids.index("SB2")
    bar_residual = (np.linalg.norm(centres[a] - centres[b]) - bar.length) / bar.u
    assert r[-1] == pytest.approx(bar_residual, abs=1e-9)
    assert jac.shape == (p.n_rows, p.n_unknowns)
    r_only, nothing = p.evaluate(x, jacobian=False)
    assert nothing is None
    np.testing.assert_array_equal(r_only, r)
    for j in range(p.n_unknowns):
        h = 10.0 * m.parameter_scales[j] if j < m.n_params else 1e-3
        e = np.zeros(p.n_unknowns)
        e[j] = h
        fd = (p.evaluate(x + e, False)[0] - p.evaluate(x - e, False)[0]) / (2 * h)
        scale = max(np.abs(jac[:, j]).max(), 1.0)
        assert np.abs(fd - jac[:, j]).max() <= 1e-6 * scale, p.names[j]
