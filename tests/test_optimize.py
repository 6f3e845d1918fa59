"""The least-squares core: every status reached on purpose, batched forms against single solves."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mtmetrology.optimize import (
    STATUS_MESSAGES,
    Status,
    cholesky_solve,
    chord_batch,
    least_squares,
    least_squares_batch,
    solve_equations,
)

T = np.linspace(0.0, 2.0, 15)


def exponential(y):
    """Residuals of y ≈ a·exp(b·t) and their Jacobian."""

    def fun(x):
        e = np.exp(x[1] * T)
        return x[0] * e - y, np.column_stack([e, x[0] * T * e])

    return fun


def test_exact_data_are_fitted_exactly_and_the_status_says_why():
    y = 3.0 * np.exp(-0.7 * T)
    res = least_squares(exponential(y), np.array([1.0, 0.0]), residual_rounding=1e-15)
    assert res.status in (Status.STEP_TOLERANCE, Status.ROUNDING_LEVEL)
    assert res.success and res.message == STATUS_MESSAGES[Status(res.status)]
    np.testing.assert_allclose(res.x, [3.0, -0.7], rtol=1e-12)
    assert res.cost < 1e-25 and res.nfev == res.njev >= res.nit


def test_iteration_limit_is_a_status_not_an_exception():
    y = 3.0 * np.exp(-0.7 * T)
    res = least_squares(exponential(y), np.array([1.0, 0.0]), max_iter=1)
    assert res.status == Status.ITERATION_LIMIT and not res.success and res.nit == 1


def test_non_finite_residuals_stop_with_their_status():
    res = least_squares(lambda x: (np.array([np.nan, 1.0]), np.eye(2)), np.zeros(2))
    assert res.status == Status.NOT_FINITE and not res.success


def test_no_descent_direction_reaches_the_damping_limit():
    """A Jacobian that lies (wrong sign) makes every step increase the cost."""
    res = least_squares(lambda x: (x - 1.0, -np.eye(2)), np.zeros(2))
    assert res.status == Status.DAMPING_LIMIT and not res.success


def test_rank_deficiency_is_refused_when_full_rank_is_required():
    jac = np.array([[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]])
    res = least_squares(lambda x: (jac @ x - 1.0, jac), np.zeros(2), require_full_rank=True)
    assert res.status == Status.RANK_DEFICIENT and res.rank == 1 and res.nit == 0
    # without the requirement: the minimum-norm solution (both unknowns equal)
    res = least_squares(lambda x: (jac @ x - 1.0, jac), np.zeros(2))
    assert res.success and res.rank == 1
    np.testing.assert_allclose(res.x, [3 / 14, 3 / 14], rtol=1e-12)  # (a + b) = 6/14


def test_covariance_is_the_inverse_normal_matrix():
    rng = np.random.default_rng(1)
    jac = rng.normal(size=(20, 4)) * [1.0, 1e3, 1e-3, 5.0]  # badly scaled columns
    b = rng.normal(size=20)
    res = least_squares(lambda x: (jac @ x - b, jac), np.zeros(4))
    np.testing.assert_allclose(res.covariance(), np.linalg.inv(jac.T @ jac), rtol=1e-9)
    np.testing.assert_allclose(res.x, np.linalg.lstsq(jac, b, rcond=None)[0], rtol=1e-10)
    assert res.condition == pytest.approx(np.linalg.cond(jac / np.linalg.norm(jac, axis=0)))


def test_a_retraction_keeps_the_state_on_its_manifold():
    """Fit a unit direction (2-D angle state) to points on a line through the origin."""
    d = np.array([0.6, 0.8])
    pts = np.outer(np.linspace(-1, 1, 9), d)

    def fun(state):
        n = np.array([-state[1], state[0]])  # normal of the line
        return pts @ n, (pts @ np.array([-state[0], -state[1]]))[:, None]

    def retract(state, step):
        c, s = np.cos(step[0]), np.sin(step[0])
        return np.array([c * state[0] - s * state[1], s * state[0] + c * state[1]])

    res = least_squares(fun, np.array([1.0, 0.0]), retract=retract, residual_rounding=1e-16)
    assert res.success
    np.testing.assert_allclose(np.abs(res.x @ d), 1.0, atol=1e-12)


def circle_normal_equations(points):
    """Stacked normal equations of the geometric circle fit (centre x, y, radius)."""

    def normal_equations(x, index):
        p = points[index]  # (k, n, 2)
        diff = p - x[:, None, :2]
        rho = np.linalg.norm(diff, axis=2)
        r = rho - x[:, 2:3]
        jac = np.concatenate([-diff / rho[..., None], -np.ones((*r.shape, 1))], axis=2)
        a = np.einsum("kni,knj->kij", jac, jac)
        g = np.einsum("kni,kn->ki", jac, r)
        return a, g, np.einsum("kn,kn->k", r, r), p.shape[1]

    return normal_equations


def test_batched_solves_agree_with_single_solves():
    rng = np.random.default_rng(7)
    k, n = 50, 12
    centres = rng.normal(size=(k, 2)) * 10
    radii = rng.uniform(1, 5, k)
    angles = rng.uniform(0, 2 * np.pi, (k, n))
    points = centres[:, None] + radii[:, None, None] * np.stack(
        [np.cos(angles), np.sin(angles)], axis=2
    )
    points += 1e-3 * rng.normal(size=points.shape)
    x0 = np.c_[points.mean(axis=1) + 0.3, radii * 1.2]
    batch = least_squares_batch(circle_normal_equations(points), x0, residual_rounding=1e-14)
    assert batch.success.all() and "all 50" in batch.message
    for i in range(0, k, 7):

        def fun(x, i=i):
            diff = points[i] - x[:2]
            rho = np.linalg.norm(diff, axis=1)
            return rho - x[2], np.c_[-diff / rho[:, None], -np.ones(n)]

        single = least_squares(fun, x0[i], residual_rounding=1e-14)
        np.testing.assert_allclose(batch.x[i], single.x, atol=1e-11)
        assert batch.cost[i] == pytest.approx(single.cost, rel=1e-9)


def test_batch_iteration_limit_and_singular_systems_are_per_problem():
    rng = np.random.default_rng(2)
    angles = rng.uniform(0, 2 * np.pi, (3, 10))
    points = np.stack([np.cos(angles), np.sin(angles)], axis=2)
    points[2] = 0.0  # all points equal: a singular system
    x0 = np.array([[0.5, 0.5, 2.0], [0.1, 0.0, 1.0], [1.0, 1.0, 1.0]])
    res = least_squares_batch(circle_normal_equations(points), x0, max_iter=1)
    assert res.status[0] == Status.ITERATION_LIMIT and not res.success[0]
    assert res.status[2] == Status.NOT_FINITE


def _circle_and_line(scale):
    def fun(v):
        x, y = v
        r = np.array([x * x + y * y - 25.0, x - y - 1.0])
        return scale * r, scale * np.array([[2 * x, 2 * y], [1.0, -1.0]])

    return fun


@pytest.mark.parametrize("scale", [1e-6, 1e6])
def test_solve_equations_finds_an_exact_root_whatever_the_units_of_the_equations(scale):
    """x² + y² = 25 and x − y = 1 meet at (4, 3).  From (5, 1) Newton's first step raises
    ‖r‖ and is damped.  The tolerance is relative to the size of the equations' terms, so
    multiplying the equations by 10⁶ or 10⁻⁶ changes neither the root nor the path."""
    reference = solve_equations(_circle_and_line(1.0), np.array([5.0, 1.0]))
    res = solve_equations(_circle_and_line(scale), np.array([5.0, 1.0]))
    assert reference.status == res.status == Status.STEP_TOLERANCE
    assert res.nit == reference.nit <= 15
    np.testing.assert_allclose(
        res.x, [4.0, 3.0], atol=1e-11
    )  # the last step (< rtol·s) is not applied
    singular = solve_equations(lambda v: (v - 1.0, np.zeros((2, 2))), np.zeros(2))
    assert singular.status == Status.RANK_DEFICIENT


@pytest.mark.parametrize("order", [1, 4, 6, 7, 12])  # written-out recurrences up to 6, LAPACK above
def test_cholesky_solve_agrees_with_a_dense_solve_and_flags_indefinite_systems(order):
    rng = np.random.default_rng(order)
    factors = rng.normal(size=(5, order, order))
    a = factors @ np.swapaxes(factors, 1, 2) + order * np.eye(order)
    a[3] = -np.eye(order)  # negative definite: refused, not solved
    b = rng.normal(size=(5, order))
    x, ok = cholesky_solve(a, b)
    assert ok.tolist() == [True, True, True, False, True]
    assert np.isnan(x[3]).all()
    good = [0, 1, 2, 4]
    np.testing.assert_allclose(x[good], np.linalg.solve(a[good], b[good][..., None])[..., 0])


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(1e-4, 1e-2))
def test_chord_iteration_reaches_the_least_squares_solution_of_each_trial(seed, noise):
    """Perturbed data, one shared Jacobian: each trial converges to within second order of
    its own least-squares solution (here 1e-9 of the parameters)."""
    rng = np.random.default_rng(seed)
    y0 = 3.0 * np.exp(-0.7 * T)
    x_hat = np.array([3.0, -0.7])
    _, jac0 = exponential(y0)(x_hat)
    ys = y0 + noise * rng.normal(size=(6, T.size))

    def residuals(x, index):
        return x[:, :1] * np.exp(x[:, 1:] * T) - ys[index]

    res = chord_batch(residuals, np.tile(x_hat, (6, 1)), jac0, xtol=1e-12)
    assert res.success.all() and res.nit.max() <= 12
    for k in range(6):
        exact = least_squares(exponential(ys[k]), x_hat, residual_rounding=1e-15)
        np.testing.assert_allclose(res.x[k], exact.x, atol=50 * noise**2 + 1e-12)


def test_chord_marks_a_perturbation_it_cannot_follow():
    y0 = 3.0 * np.exp(-0.7 * T)
    x_hat = np.array([3.0, -0.7])
    _, jac0 = exponential(y0)(x_hat)
    ys = np.stack([y0, -5.0 * np.exp(0.9 * T)])  # the second: far outside the chord's reach

    def residuals(x, index):
        return x[:, :1] * np.exp(x[:, 1:] * T) - ys[index]

    res = chord_batch(residuals, np.tile(x_hat, (2, 1)), jac0, max_iter=5)
    assert res.status[0] == Status.STEP_TOLERANCE
    assert res.status[1] <= 0 and not res.success[1]


def test_chord_final_step_applied_costs_no_evaluation_and_tightens_the_solution():
    """With a loose xtol the converged step is applied: one evaluation fewer than a tight
    xtol needs, and an error of the order of rate × xtol instead of xtol."""
    rng = np.random.default_rng(7)
    y0 = 3.0 * np.exp(-0.7 * T)
    x_hat = np.array([3.0, -0.7])
    _, jac0 = exponential(y0)(x_hat)
    ys = y0 + 1e-3 * rng.normal(size=(4, T.size))

    def residuals(x, index):
        return x[:, :1] * np.exp(x[:, 1:] * T) - ys[index]

    start = np.tile(x_hat, (4, 1))
    tight = chord_batch(residuals, start, jac0, xtol=1e-14)
    loose = chord_batch(residuals, start, jac0, xtol=1e-3)
    final = chord_batch(residuals, start, jac0, xtol=1e-3, apply_final_step=True)
    assert final.nfev == loose.nfev < tight.nfev
    err_loose = np.abs(loose.x - tight.x).max()
    err_final = np.abs(final.x - tight.x).max()
    assert err_final < 1e-3 * err_loose


@pytest.mark.parametrize("rank_deficient", [False, True])
def test_tall_problems_factorised_by_block_qr_agree_with_the_thin_svd(monkeypatch, rank_deficient):
    """Above the tall-problem threshold the solver uses a block-accumulated QR instead of
    the thin SVD: status, solution, singular values, rank, condition and covariance agree
    with the SVD path to rounding (a quadratic model, so the solution is exact)."""
    import mtmetrology.optimize as optimize

    rng = np.random.default_rng(7)
    t = rng.uniform(-1.0, 1.0, 50_000)
    basis = np.column_stack([np.ones_like(t), t, 1e3 * t**2, t if rank_deficient else t**3])
    y = basis @ np.array([1.0, -2.0, 0.5e-3, 0.25]) + rng.normal(scale=1e-3, size=t.size)

    def fun(x):
        return basis @ x - y, basis

    def solve():
        return least_squares(fun, np.zeros(4), residual_rounding=1e-16, xtol=1e-12)

    assert optimize._tall(basis)
    lean = solve()
    monkeypatch.setattr(optimize, "_TALL_ROWS", 10 * t.size)
    assert not optimize._tall(basis)
    thin = solve()
    assert lean.status == thin.status and lean.status > 0
    assert lean.rank == thin.rank == (3 if rank_deficient else 4)
    np.testing.assert_allclose(lean.singular_values, thin.singular_values, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(lean.x, thin.x, rtol=0, atol=1e-10)
    np.testing.assert_allclose(lean.covariance(), thin.covariance(), rtol=1e-9, atol=1e-15)
    if not rank_deficient:
        assert lean.condition == pytest.approx(thin.condition, rel=1e-10)


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_a_tall_problem_holds_one_jacobian_at_a_time(sign):
    """Above the tall-problem threshold the iteration needs only the SVD pieces, so the
    current Jacobian is let go before a trial point is evaluated: when ``fun`` is called,
    no Jacobian it returned before is still alive.  A sign-flipped Jacobian makes every
    step go uphill (damping limit after rejected trials): the final point's Jacobian is
    then evaluated once more, counted in ``nfev``, and is the one of the returned ``x``."""
    import weakref

    import mtmetrology.optimize as optimize

    rng = np.random.default_rng(11)
    a = rng.normal(size=(30_000, 3))
    b = a @ np.array([1.0, -2.0, 0.5]) + 1e-3 * rng.normal(size=a.shape[0])
    handed_out = []
    alive_at_call = []

    def fun(x):
        alive_at_call.append(sum(ref() is not None for ref in handed_out))
        jac = sign * a
        handed_out.append(weakref.ref(jac))
        return a @ x - b, jac

    assert optimize._tall(a)
    res = least_squares(fun, np.zeros(3))
    assert alive_at_call == [0] * len(alive_at_call)
    assert res.nfev == res.njev == len(handed_out)
    np.testing.assert_array_equal(res.jacobian, sign * a)
    if sign > 0:
        assert res.status == Status.STEP_TOLERANCE
        np.testing.assert_allclose(res.x, np.linalg.lstsq(a, b, rcond=None)[0], atol=1e-12)
    else:
        # the undamped step and λ = 1e-3 ... 1e12: 17 rejected trials, then the start
        # evaluated again
        assert res.status == Status.DAMPING_LIMIT
        assert res.nit == 17 and res.nfev == 1 + 17 + 1
        np.testing.assert_array_equal(res.x, np.zeros(3))
