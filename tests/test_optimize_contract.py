"""The least-squares core's contract: certified solutions, counts, defaults, result fields.

Reference values are NIST StRD certified results (Misra1a: b1 = 2.3894212918E+02,
b2 = 5.5015643181E-04, residual sum of squares 1.2455138894E-01, residual standard
deviation 1.0187876330E-01) or exact solutions (linear problems by numpy's lstsq).
Counts are checked against a counter around the caller's function, never against the
solver's own numbers.
"""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.optimize import Status, chord_batch, least_squares, least_squares_batch

X = np.array([77.6, 114.9, 141.1, 190.8, 239.9, 289.0, 332.8, 378.4, 434.8, 477.3, 536.8])
X = np.r_[X, 593.1, 689.1, 760.0]
Y = np.array([10.07, 14.73, 17.94, 23.93, 29.61, 35.18, 40.02, 44.82, 50.76, 55.05, 61.01])
Y = np.r_[Y, 66.40, 75.47, 81.78]
CERTIFIED = np.array([2.3894212918e02, 5.5015643181e-04])
CERTIFIED_RSS = 1.2455138894e-01


class Counted:
    """A problem function that counts its calls."""

    def __init__(self, fun):
        self.fun, self.calls = fun, 0

    def __call__(self, x):
        self.calls += 1
        return self.fun(x)


def misra1a(b):
    e = np.exp(-b[1] * X)
    return b[0] * (1.0 - e) - Y, np.column_stack([1.0 - e, b[0] * X * e])


@pytest.mark.parametrize("start", [(500.0, 1e-4), (250.0, 5e-4)])
def test_misra1a_reaches_the_certified_values_from_both_nist_starts(start):
    """With the defaults (xtol 1e-10, no rounding unit, 100 iterations): converged on the
    step, to 10 significant digits.  Start 1 needs damped steps far from the solution."""
    fun = Counted(misra1a)
    x0 = np.array(start)
    res = least_squares(fun, x0)
    assert res.status == Status.STEP_TOLERANCE and res.success
    np.testing.assert_allclose(res.x, CERTIFIED, rtol=1e-9)
    assert 2.0 * res.cost == pytest.approx(CERTIFIED_RSS, rel=1e-9)
    assert res.nfev == res.njev == fun.calls and 1 <= res.nit <= 100
    np.testing.assert_array_equal(x0, start)  # the start is not modified
    # the result's residuals and Jacobian are those at its x
    r, jac = misra1a(res.x)
    np.testing.assert_array_equal(res.residuals, r)
    np.testing.assert_array_equal(res.jacobian, jac)
    assert res.rank == 2 and res.n_unknowns == 2
    # condition number of the column-scaled Jacobian
    scaled = jac / np.linalg.norm(jac, axis=0)
    assert res.condition == pytest.approx(np.linalg.cond(scaled), rel=1e-9)


def test_certified_standard_deviation_from_the_covariance():
    res = least_squares(misra1a, np.array([250.0, 5e-4]))
    s2 = 2.0 * res.cost / (X.size - 2)
    assert np.sqrt(s2) == pytest.approx(1.0187876330e-01, rel=1e-9)
    assert np.sqrt(s2 * res.covariance()[0, 0]) == pytest.approx(2.7070075241e00, rel=1e-8)


def slow_problem(x):
    """A Jacobian 1000 times too large: every step is 1/1000 of the Gauss-Newton step and
    lowers the cost, so the iteration crawls and only the iteration limit stops it."""
    return x - 1.0, 1000.0 * np.eye(2)


def test_the_default_iteration_limit_is_100():
    fun = Counted(slow_problem)
    res = least_squares(fun, np.zeros(2))
    assert res.status == Status.ITERATION_LIMIT and res.nit == 100
    assert fun.calls == res.nfev == 101
    # each accepted step moved x by 1/1000 of the remaining distance
    np.testing.assert_allclose(res.x, 1.0 - 0.999**100, rtol=1e-12)
    res = least_squares(slow_problem, np.zeros(2), max_iter=7)
    assert res.nit == 7 and res.nfev == 8


def test_rounding_level_stop_when_steps_no_longer_contract():
    """xtol = 0 can never be met; with the rounding unit of the residuals the iteration
    stops at the rounding level with the least-squares solution."""
    rng = np.random.default_rng(3)
    a = rng.normal(size=(30, 3))
    b = a @ [1.0, -2.0, 0.5] + 0.01 * rng.normal(size=30)
    exact = np.linalg.lstsq(a, b, rcond=None)[0]
    res = least_squares(lambda x: (a @ x - b, a), np.zeros(3), xtol=0.0, residual_rounding=1e-15)
    assert res.status == Status.ROUNDING_LEVEL and res.nit < 10
    np.testing.assert_allclose(res.x, exact, atol=1e-12)
    assert res.cost == pytest.approx(0.5 * np.sum((a @ exact - b) ** 2), rel=1e-12)


def test_early_stops_report_the_start():
    x0 = np.array([1.0, 2.0])
    res = least_squares(lambda x: (np.array([np.inf, 0.0, 1.0]), np.ones((3, 2))), x0)
    assert res.status == Status.NOT_FINITE
    assert res.x is x0 and res.nit == 0 and res.nfev == res.njev == 1
    assert np.isnan(res.cost) and res.residuals.shape == (3,) and res.jacobian.shape == (3, 2)
    jac = np.array([[1.0, 1.0], [1.0, 1.0], [2.0, 2.0]])
    res = least_squares(lambda x: (jac @ x - 1.0, jac), x0, require_full_rank=True)
    assert res.status == Status.RANK_DEFICIENT
    assert res.x is x0 and res.nit == 0 and res.nfev == res.njev == 1
    assert res.rank == 1 and res.condition == np.inf
    np.testing.assert_array_equal(res.residuals, jac @ x0 - 1.0)
    assert res.cost == pytest.approx(0.5 * np.sum((jac @ x0 - 1.0) ** 2))


def test_nearly_dependent_columns_count_against_the_rank_tolerance():
    """Columns that differ by 1e-13 relative: rank 1 at rtol 1e-10 (condition infinite),
    rank 2 at rtol 1e-15 (condition finite, ~1e13)."""
    t = np.linspace(0.0, 1.0, 5)
    jac = np.column_stack([t + 1.0, (t + 1.0) * (1.0 + 1e-13 * t)])
    fun = lambda x: (jac @ x - 1.0, jac)  # noqa: E731
    loose = least_squares(fun, np.zeros(2), max_iter=1)
    assert loose.rank == 1 and loose.condition == np.inf
    tight = least_squares(fun, np.zeros(2), max_iter=1, rank_rtol=1e-15)
    assert tight.rank == 2 and 1e12 < tight.condition < 1e15
    zero = least_squares(lambda x: (np.ones(3), np.zeros((3, 2))), np.zeros(2), max_iter=1)
    assert zero.rank == 0 and zero.condition == np.inf


def test_a_zero_residual_start_stops_at_once():
    res = least_squares(lambda x: (np.zeros(3), np.eye(3)), np.ones(3))
    assert res.status == Status.STEP_TOLERANCE and res.nit == 1 and res.nfev == 1
    assert res.cost == 0.0


# ------------------------------------------------------------------ batched forms


def exponential_batch(y):
    t = np.linspace(0.0, 2.0, y.shape[1])

    def normal_equations(x, index):
        e = np.exp(x[:, 1:2] * t)
        r = x[:, :1] * e - y[index]
        jac = np.stack([e, x[:, :1] * t * e], axis=2)
        calls.append(index.size)
        return (
            np.einsum("kmi,kmj->kij", jac, jac),
            np.einsum("kmi,km->ki", jac, r),
            np.einsum("km,km->k", r, r),
            t.size,
        )

    calls: list[int] = []
    return normal_equations, calls


def test_batch_matches_single_solves_costs_counts_and_leaves_the_start_alone():
    t = np.linspace(0.0, 2.0, 15)
    rng = np.random.default_rng(5)
    truth = np.c_[rng.uniform(1, 4, 6), rng.uniform(-1.5, -0.2, 6)]
    y = truth[:, :1] * np.exp(truth[:, 1:] * t) + 1e-3 * rng.normal(size=(6, 15))
    x0 = np.tile([1.0, 0.0], (6, 1))
    start = x0.copy()
    normal_equations, calls = exponential_batch(y)
    res = least_squares_batch(normal_equations, x0, xtol=1e-12)
    np.testing.assert_array_equal(x0, start)
    assert res.success.all() and res.nfev == len(calls)
    assert np.all(res.nit >= 1) and res.nit.max() <= 100
    for k in range(6):

        def fun(x, k=k):
            e = np.exp(x[1] * t)
            return x[0] * e - y[k], np.column_stack([e, x[0] * t * e])

        single = least_squares(fun, start[k], xtol=1e-12)
        np.testing.assert_allclose(res.x[k], single.x, rtol=1e-9)
        r = res.x[k, 0] * np.exp(res.x[k, 1] * t) - y[k]
        assert res.cost[k] == pytest.approx(0.5 * r @ r, rel=1e-12)


def test_batch_defaults_and_limits_are_per_problem():
    """The default limit is 100 iterations; a crawling problem (Jacobian 1000× too large)
    reaches it while a well-posed one converges."""

    def normal_equations(x, index):
        scale = np.where(index == 0, 1000.0, 1.0)[:, None, None]
        jac = scale * np.eye(2)
        r = x - 1.0
        g = np.einsum("kmi,km->ki", jac, r)
        return np.einsum("kmi,kmj->kij", jac, jac), g, np.einsum("km,km->k", r, r), 2

    res = least_squares_batch(normal_equations, np.zeros((2, 2)), xtol=1e-12)
    assert res.status[0] == Status.ITERATION_LIMIT and res.nit[0] == 100
    assert res.status[1] == Status.STEP_TOLERANCE and res.nit[1] == 2
    np.testing.assert_allclose(res.x[0], 1.0 - 0.999**100, rtol=1e-12)
    np.testing.assert_allclose(res.x[1], 1.0, atol=1e-15)


def test_batch_damping_recovers_from_a_bad_start():
    """From far away the undamped step overshoots; the damped iteration still reaches
    the single-solve solution, within the iteration limit."""
    t = np.linspace(0.0, 2.0, 15)
    y = (3.0 * np.exp(-1.2 * t))[None, :]
    normal_equations, _ = exponential_batch(y)
    res = least_squares_batch(normal_equations, np.array([[0.1, 2.0]]), xtol=1e-12)
    assert res.success[0]
    np.testing.assert_allclose(res.x[0], [3.0, -1.2], rtol=1e-9)


def test_chord_counts_costs_and_start():
    t = np.linspace(0.0, 2.0, 15)
    y0 = 3.0 * np.exp(-0.7 * t)
    x_hat = np.array([3.0, -0.7])
    jac0 = np.column_stack([np.exp(-0.7 * t), 3.0 * t * np.exp(-0.7 * t)])
    ys = y0 + 1e-3 * np.random.default_rng(1).normal(size=(4, 15))
    calls = []

    def residuals(x, index):
        calls.append(index.size)
        return x[:, :1] * np.exp(x[:, 1:] * t) - ys[index]

    x0 = np.tile(x_hat, (4, 1))
    start = x0.copy()
    res = chord_batch(residuals, x0, jac0, xtol=1e-12)
    np.testing.assert_array_equal(x0, start)
    assert res.success.all() and res.nfev == len(calls) and calls[0] == 4
    r = res.x[:, :1] * np.exp(res.x[:, 1:] * t) - ys
    np.testing.assert_allclose(res.cost, 0.5 * np.sum(r**2, axis=1), rtol=1e-12)
    # each iteration is one step; the last evaluation only confirms convergence
    assert np.all(res.nit >= 1) and res.nit.max() == len(calls) - 1
    one = chord_batch(residuals, x0, jac0, xtol=1e-12, max_iter=1)
    assert np.all(one.nit == 1) and np.all(one.status == Status.ITERATION_LIMIT)


def line_normal_equations(y, t):
    """Stacked normal equations of straight-line fits y_k ≈ a_k + b_k t (linear)."""
    design = np.column_stack([np.ones_like(t), t])

    def normal_equations(x, index):
        r = x @ design.T - y[index]
        a = np.broadcast_to(design.T @ design, (index.size, 2, 2)).copy()
        return a, r @ design, np.einsum("km,km->k", r, r), t.size

    return normal_equations


def test_batch_with_a_singular_system_first_still_solves_the_others():
    """The batched Cholesky fails on problem 0 (all-zero design); the others are solved
    one by one and reach numpy's lstsq solution."""
    t = np.linspace(0.0, 1.0, 6)
    rng = np.random.default_rng(8)
    y = rng.normal(size=(5, 6))
    regular = line_normal_equations(y, t)

    def normal_equations(x, index):
        a, g, rr, m = regular(x, index)
        a[index == 0] = 0.0
        g[index == 0] = 0.0
        return a, g, rr, m

    res = least_squares_batch(normal_equations, np.zeros((5, 2)), xtol=1e-12)
    assert res.status[0] == Status.NOT_FINITE
    design = np.column_stack([np.ones_like(t), t])
    for k in range(1, 5):
        assert res.status[k] > 0
        np.testing.assert_allclose(res.x[k], np.linalg.lstsq(design, y[k], rcond=None)[0])


def test_batch_default_tolerance_on_exact_data():
    """With the default xtol = 0, exact data stop every problem on the exact solution (a
    zero step, or the rounding level), in a few iterations."""
    t = np.linspace(0.0, 1.0, 8)
    truth = np.array([[1.0, 2.0], [-3.0, 0.5], [0.25, -1.0]])
    y = truth @ np.vstack([np.ones_like(t), t])
    res = least_squares_batch(
        line_normal_equations(y, t), np.zeros((3, 2)), residual_rounding=1e-15
    )
    assert res.success.all() and res.nit.max() < 10
    np.testing.assert_allclose(res.x, truth, atol=1e-12)


def test_batch_retraction_is_used_and_can_refuse_a_step():
    """The retraction sees the problems' indices; a problem whose every trial is refused
    keeps its start and ends at the damping limit, the others converge."""
    t = np.linspace(0.0, 1.0, 6)
    y = np.array([1.0 + 2.0 * t, 3.0 - t, 0.5 * t])
    seen = []

    def retract(x, steps, index):
        seen.append(np.array(index))
        return x + steps, [k != 1 for k in index]

    x0 = np.zeros((3, 2))
    res = least_squares_batch(line_normal_equations(y, t), x0, retract=retract, xtol=1e-12)
    assert seen and all(s.dtype.kind == "i" for s in seen) and 1 in seen[0]
    assert res.status[1] == Status.DAMPING_LIMIT
    np.testing.assert_array_equal(res.x[1], [0.0, 0.0])
    np.testing.assert_allclose(res.x[[0, 2]], [[1.0, 2.0], [0.0, 0.5]], atol=1e-12)


def test_chord_default_tolerance_reaches_each_trials_solution():
    """With the default xtol (1e-8 in units of the residuals) every trial moves from the
    shared start to its own least-squares solution."""
    t = np.linspace(0.0, 2.0, 15)
    x_hat = np.array([3.0, -0.7])
    y0 = 3.0 * np.exp(-0.7 * t)
    jac0 = np.column_stack([np.exp(-0.7 * t), 3.0 * t * np.exp(-0.7 * t)])
    ys = y0 + 1e-3 * np.random.default_rng(4).normal(size=(3, 15))

    def residuals(x, index):
        return x[:, :1] * np.exp(x[:, 1:] * t) - ys[index]

    res = chord_batch(residuals, np.tile(x_hat, (3, 1)), jac0)
    assert res.success.all()
    for k in range(3):

        def fun(x, k=k):
            e = np.exp(x[1] * t)
            return x[0] * e - ys[k], np.column_stack([e, x[0] * t * e])

        exact = least_squares(fun, x_hat, xtol=1e-12).x
        assert np.abs(res.x[k] - x_hat).max() > 1e-5  # it moved
        np.testing.assert_allclose(res.x[k], exact, atol=1e-6)


def test_rank_and_condition_of_small_and_orthogonal_problems():
    """One unknown: rank 1, condition 1.  Orthogonal unit columns (s_max = 1): full rank.
    A full-rank problem passes the full-rank requirement."""
    one = least_squares(lambda x: (np.array([x[0] - 2.0, x[0] + 1.0]), np.ones((2, 1))), [0.0])
    assert one.rank == 1 and one.condition == 1.0 and one.success
    assert one.x[0] == pytest.approx(0.5)
    eye = least_squares(lambda x: (x - 1.0, np.eye(3)), np.zeros(3), require_full_rank=True)
    assert eye.rank == 3 and eye.condition == pytest.approx(1.0) and eye.success
    np.testing.assert_allclose(eye.x, 1.0)


def test_a_non_finite_jacobian_is_caught_at_the_start_and_at_trials():
    start = least_squares(lambda x: (x - 1.0, np.full((2, 2), np.nan)), np.zeros(2))
    assert start.status == Status.NOT_FINITE and start.nit == 0

    def fun(x):  # finite residuals everywhere, a Jacobian that fails away from the start
        jac = np.eye(2) if np.all(x == 0.0) else np.full((2, 2), np.nan)
        return x - 1.0, jac

    res = least_squares(fun, np.zeros(2))
    assert res.status == Status.DAMPING_LIMIT
    np.testing.assert_array_equal(res.x, [0.0, 0.0])
    np.testing.assert_array_equal(res.jacobian, np.eye(2))
