"""The one non-linear least-squares core: Gauss–Newton with a Levenberg–Marquardt safeguard.

Every iterative least-squares solve of mtmetrology — the identification of machine errors,
the geometric-element fits, the implicit GUF models, and their batched Monte Carlo forms —
runs here, so they stop for the same reasons and report them the same way: an integer
``status`` from one table, :data:`STATUS_MESSAGES`, from which ``success`` and ``message``
are derived (as in :func:`scipy.optimize.least_squares`).

Four entry points:

:func:`least_squares`
    One problem ``fun(x) -> (r, J)``.  Column scaling ``J_s = J D⁻¹``, ``D = diag‖J_:,j‖``
    (unit-norm columns); one SVD ``J_s = U S Vᵀ`` per accepted point serves the
    Gauss–Newton step, the Levenberg–Marquardt steps (Moré's scaling is the identity in
    scaled coordinates), the rank, the condition number and the covariance.  For tall
    problems (many more residuals than unknowns: element fits to millions of points) the
    SVD is taken of the R factor of a QR accumulated over row blocks, which has the same
    ``S`` and ``V`` and needs no (m, n) factor in memory.
:func:`solve_equations`
    A square system ``r(x) = 0`` (implicit measurement models): Newton's method, which is
    the Gauss–Newton step of :func:`least_squares` when ``J`` is square, with a relative
    step tolerance.
:func:`least_squares_batch`
    K independent problems of a few unknowns (batched element fits): the problem supplies
    the stacked normal equations ``JᵀJ, Jᵀr, rᵀr``; damping, acceptance and convergence are
    decided per problem.
:func:`chord_batch`
    K perturbed copies of one solved problem (Monte Carlo of an identification): every
    trial starts at the solution and reuses its factorised Jacobian, ``Δx = −J₀⁺ r(x)``,
    with exact residuals and convergence checked per trial.

Steps
-----
With ``r``, ``J`` at the current point and the SVD of ``J_s``::

    δ_s(λ) = −V diag(s / (s² + λ)) Uᵀ r,      Δx = D⁻¹ δ_s           (λ = 0: Gauss–Newton)

(singular values below ``rank_rtol·s_max`` are dropped: the minimum-norm step).  A step is
accepted when the cost ``½‖r‖²`` does not increase; otherwise λ grows tenfold from 1e-3
(Levenberg 1944; Marquardt 1963; Moré 1978, scaling by ``diag JᵀJ``), and relaxes tenfold
after each success.

Stopping (the ``status`` codes)
--------------------------------
``1`` the scaled step ``‖D Δx‖ ≤ xtol``: the step is below ``xtol`` in units of the
residuals (for weighted residuals, of the input standard uncertainties).
``2`` near the solution the decrease of the undamped step ``‖J Δx_GN‖² = ‖P_J r‖²`` is
below the rounding noise of the cost (``1e-10·‖r‖² + m·ρ²``, ρ the rounding unit of one
residual given by the caller), so the cost can no longer judge steps; the iteration stops
when the steps stop contracting.
``0`` iteration limit; ``-1`` no damped step lowers the cost (λ > 1e12); ``-2`` residuals or
Jacobian not finite; ``-3`` rank-deficient Jacobian when full rank is required.  ``3`` is
reserved for problems a caller solves exactly in closed form (SVD line and plane fits), so
that every result of the project speaks the same status language.

References
----------
K. Levenberg, "A method for the solution of certain non-linear problems in least
squares", Q. Appl. Math. 2 (1944) 164–168.
D. W. Marquardt, "An algorithm for least-squares estimation of nonlinear parameters",
J. SIAM 11 (1963) 431–441.
J. J. Moré, "The Levenberg–Marquardt algorithm: implementation and theory", in Numerical
Analysis, Lecture Notes in Mathematics 630, Springer, 1978, 105–116.
Å. Björck, *Numerical Methods for Least Squares Problems*, SIAM, 1996, §9.2 (Gauss–Newton,
column scaling) and §2.7 (the covariance ``(JᵀJ)⁻¹`` of a weighted problem).

Examples
--------
Fit ``y = a·exp(b·t)`` to exact data:

>>> import numpy as np
>>> t = np.linspace(0.0, 1.0, 11)
>>> y = 2.0 * np.exp(-1.5 * t)
>>> def fun(x):
...     e = np.exp(x[1] * t)
...     return x[0] * e - y, np.column_stack([e, x[0] * t * e])
>>> res = least_squares(fun, np.array([1.0, 0.0]), residual_rounding=1e-16)
>>> res.success, np.round(res.x, 12).tolist()
(True, [2.0, -1.5])
>>> least_squares(fun, np.array([1.0, 0.0]), max_iter=1).status
0
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import IntEnum
from typing import Any

import numpy as np

__all__ = [
    "STATUS_MESSAGES",
    "BatchLeastSquaresResult",
    "LeastSquaresResult",
    "Status",
    "cholesky_solve",
    "chord_batch",
    "least_squares",
    "least_squares_batch",
    "solve_equations",
]


class Status(IntEnum):
    """Why a least-squares iteration stopped (> 0: converged)."""

    RANK_DEFICIENT = -3
    NOT_FINITE = -2
    DAMPING_LIMIT = -1
    ITERATION_LIMIT = 0
    STEP_TOLERANCE = 1
    ROUNDING_LEVEL = 2
    EXACT = 3


STATUS_MESSAGES = {
    Status.RANK_DEFICIENT: "the column-scaled Jacobian is rank deficient",
    Status.NOT_FINITE: "residuals or Jacobian are not finite at the current point",
    Status.DAMPING_LIMIT: "no damped step lowers the cost (damping limit reached)",
    Status.ITERATION_LIMIT: "the iteration limit was reached",
    Status.STEP_TOLERANCE: "converged: the scaled step is below xtol",
    Status.ROUNDING_LEVEL: "converged: the steps stopped contracting at the rounding level",
    Status.EXACT: "solved exactly in closed form (no iteration)",
}

# Steps whose predicted relative cost decrease is below this are judged by their size, not
# by the (rounding-level) change of the cost.
_NEAR_REL = 1e-10
# Cost increase tolerated near the solution, where the cost changes only by rounding.
_NEAR_SLACK = 1e-9
_LAMBDA_START = 1e-3
_LAMBDA_MAX = 1e12


def _message(status: int) -> str:
    return STATUS_MESSAGES[Status(int(status))]


@dataclass(frozen=True, eq=False)
class LeastSquaresResult:
    """Result of :func:`least_squares` (the fields of :class:`scipy.optimize.OptimizeResult`
    that apply, plus the SVD the diagnostics reuse).

    Attributes
    ----------
    x : ndarray or object
        The solution (a state object when a ``retract`` was given).
    cost : float
        ``½‖r‖²`` at ``x``.
    residuals : (m,) ndarray
    jacobian : (m, n) ndarray
    column_norms : (n,) ndarray
        ``D``: the 2-norms of the Jacobian's columns (1 for a zero column).
    singular_values : (min(m, n),) ndarray
        Of the column-scaled Jacobian ``J D⁻¹``, descending.
    right_singular_vectors : (min(m, n), n) ndarray
        ``Vᵀ`` of the column-scaled Jacobian.
    rank : int
        Singular values above ``rank_rtol·s_max``.
    condition : float
        ``s_max / s_min`` of the column-scaled Jacobian (inf when rank deficient).
    nfev, njev, nit : int
        Residual and Jacobian evaluations, iterations.
    status : int
        A :class:`Status` code; see :data:`STATUS_MESSAGES`.
    """

    x: Any
    cost: float
    residuals: np.ndarray = field(repr=False)
    jacobian: np.ndarray = field(repr=False)
    column_norms: np.ndarray = field(repr=False)
    singular_values: np.ndarray = field(repr=False)
    right_singular_vectors: np.ndarray = field(repr=False)
    rank: int
    condition: float
    nfev: int
    njev: int
    nit: int
    status: int

    @property
    def success(self) -> bool:
        """Whether the iteration converged (``status > 0``)."""
        return self.status > 0

    @property
    def message(self) -> str:
        return _message(self.status)

    @property
    def n_unknowns(self) -> int:
        return self.jacobian.shape[1]

    def covariance(self) -> np.ndarray:
        """``(JᵀJ)⁻¹`` from the SVD, ``D⁻¹ V S⁻² Vᵀ D⁻¹``; the pseudo-inverse over the rank
        when rank deficient (the minimum-norm covariance)."""
        s = self.singular_values[: self.rank]
        v = self.right_singular_vectors[: self.rank] / self.column_norms  # (rank, n)
        return (v.T / s**2) @ v


#: From this many residuals on (and at least :data:`_TALL_RATIO` per unknown),
#: :func:`least_squares` factorises the column-scaled Jacobian by a QR accumulated over
#: row blocks of :data:`_BLOCK_ROWS` instead of a thin SVD, so that no (m, n) factor is held.
_TALL_ROWS = 20_000
_TALL_RATIO = 16
_BLOCK_ROWS = 32_768


def _scaled_svd(jac: np.ndarray):
    norms = np.linalg.norm(jac, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    u, s, vt = np.linalg.svd(jac / norms, full_matrices=False)
    return norms, u, s, vt


def _tall(jac: np.ndarray) -> bool:
    m, n = jac.shape
    return m >= _TALL_ROWS and m >= _TALL_RATIO * max(n, 1)


def _projected(jac: np.ndarray, r: np.ndarray):
    """The scaled SVD pieces the iteration uses, with ``Uᵀr`` in place of ``U``.

    Small problems: the thin SVD of ``J_s = J D⁻¹``.  Tall ones: the R factor of the
    augmented ``[J_s | r] = Q [[R, Qᵀr], [0, ρ]]``, accumulated block by block (each block
    is stacked under the R so far and re-factorised: a sequential QR, Björck 1996); then
    ``R = U_R S Vᵀ`` gives the singular values and ``Vᵀ`` of ``J_s``, and
    ``Uᵀr = U_Rᵀ (Qᵀr)``.  Both are backward stable, so the steps agree to rounding, and
    memory stays at one block instead of the (m, n) factor ``U``.
    """
    if not _tall(jac):
        norms = np.linalg.norm(jac, axis=0)
        norms = np.where(norms > 0, norms, 1.0)
        u, s, vt = np.linalg.svd(jac / norms, full_matrices=False)
        return norms, u.T @ r, s, vt
    m, n = jac.shape
    # column norms block by block too: np.linalg.norm would square the whole (m, n) matrix
    squares = np.zeros(n)
    for start in range(0, m, _BLOCK_ROWS):
        block = jac[start : start + _BLOCK_ROWS]
        squares += np.einsum("ij,ij->j", block, block)
    norms = np.sqrt(squares)
    norms = np.where(norms > 0, norms, 1.0)
    tri = np.zeros((0, n + 1))
    for start in range(0, m, _BLOCK_ROWS):
        stop = min(start + _BLOCK_ROWS, m)
        block = np.empty((stop - start, n + 1))
        np.divide(jac[start:stop], norms, out=block[:, :n])
        block[:, n] = r[start:stop]
        tri = np.linalg.qr(np.vstack([tri, block]), mode="r")[: n + 1]
    u_r, s, vt = np.linalg.svd(tri[:n, :n])
    return norms, u_r.T @ tri[:n, n], s, vt


def _finite(*arrays) -> bool:
    return all(np.all(np.isfinite(a)) for a in arrays)


def least_squares(
    fun: Callable[[Any], tuple[np.ndarray, np.ndarray]],
    x0: Any,
    *,
    retract: Callable[[Any, np.ndarray], Any] | None = None,
    xtol: float = 1e-10,
    max_iter: int = 100,
    residual_rounding: float = 0.0,
    rank_rtol: float = 1e-10,
    require_full_rank: bool = False,
) -> LeastSquaresResult:
    """Minimise ``½‖r(x)‖²`` by Gauss–Newton with a Levenberg–Marquardt safeguard.

    Parameters
    ----------
    fun : callable
        ``fun(x) -> (r (m,), J (m, n))``: residuals and their Jacobian with respect to the
        n step coordinates.
    x0 : ndarray or object
        Starting point (a state object when ``retract`` is given).
    retract : callable, optional
        ``retract(x, step) -> x_new`` (None when the step leaves the domain); ``x + step``
        by default.  Element fits use it to move on manifolds (unit directions).
    xtol : float
        Tolerance on the scaled step ``‖D Δx‖`` (status 1).
    max_iter : int
        Iteration limit (status 0).
    residual_rounding : float
        Rounding unit ρ of one residual (e.g. ``eps·size`` of the data), for the
        rounding-level stop (status 2); 0 disables it.
    rank_rtol : float
        Singular values of the column-scaled Jacobian below ``rank_rtol·s_max`` count as
        zero (rank and minimum-norm steps).
    require_full_rank : bool
        Stop at once with status -3 when the Jacobian at ``x0`` is rank deficient.

    Returns
    -------
    LeastSquaresResult
        Never raises for a failed iteration: read ``status``/``success``.

    Notes
    -----
    See the module notes for the step and the stopping rules.  The returned point is the
    last accepted one, so ``residuals``, ``jacobian`` and the SVD all belong to ``x``; a
    converged step (below ``xtol`` or at the rounding level) is not applied.  A tall
    problem (many more residuals than unknowns) holds one (m, n) Jacobian at a time: the
    current one is released before a trial point is evaluated, and when the iteration
    stops after a rejected trial (a failed stop) ``fun(x)`` is evaluated once more for it
    (counted in ``nfev`` and ``njev``).

    References
    ----------
    D. W. Marquardt, "An algorithm for least-squares estimation of nonlinear parameters",
    J. SIAM 11 (1963) 431–441.
    J. J. Moré, "The Levenberg–Marquardt algorithm: implementation and theory", in Numerical
    Analysis, Lecture Notes in Mathematics 630, Springer, 1978, 105–116.
    NIST Statistical Reference Datasets, Nonlinear Regression, "Misra1a" (D. Misra, NIST,
    1978; certified values computed in 128-bit arithmetic), lower difficulty.

    Examples
    --------
    The NIST StRD problem Misra1a, ``y = b1·(1 − exp(−b2·x))``, from its first start
    (500, 1e-4): the certified values are b1 = 2.3894212918E+02, b2 = 5.5015643181E-04 and
    the residual sum of squares 1.2455138894E-01.

    >>> import numpy as np
    >>> x = np.array([77.6, 114.9, 141.1, 190.8, 239.9, 289.0, 332.8, 378.4, 434.8, 477.3,
    ...               536.8, 593.1, 689.1, 760.0])
    >>> y = np.array([10.07, 14.73, 17.94, 23.93, 29.61, 35.18, 40.02, 44.82, 50.76, 55.05,
    ...               61.01, 66.40, 75.47, 81.78])
    >>> def misra1a(b):
    ...     e = np.exp(-b[1] * x)
    ...     return b[0] * (1.0 - e) - y, np.column_stack([1.0 - e, b[0] * x * e])
    >>> res = least_squares(misra1a, np.array([500.0, 1e-4]))
    >>> Status(res.status).name, f"{res.x[0]:.8f}", f"{res.x[1]:.10e}", f"{2 * res.cost:.10e}"
    ('STEP_TOLERANCE', '238.94212918', '5.5015643181e-04', '1.2455138894e-01')
    """
    move = retract if retract is not None else (lambda x, step: x + step)
    x = x0
    r, jac = fun(x)
    nfev = njev = 1
    if not _finite(r, jac):
        return _result(x, r, jac, None, Status.NOT_FINITE, nfev, njev, 0, rank_rtol)
    m = r.size
    svd = _projected(jac, r)
    if require_full_rank and _rank(svd[2], rank_rtol, jac.shape[1]) < jac.shape[1]:
        return _result(x, r, jac, svd, Status.RANK_DEFICIENT, nfev, njev, 0, rank_rtol)
    rr = float(r @ r)
    # A tall problem's iteration needs only the small SVD pieces: its (m, n) Jacobian is
    # let go before a trial point is evaluated, so that two are never held at once, and
    # evaluated again at the end only if the last trial was rejected (a failed stop).
    lean = _tall(jac)
    lam = 0.0
    previous = np.inf  # last accepted step size in the near-converged regime
    status = Status.ITERATION_LIMIT
    nit = 0
    while nit < max_iter:
        nit += 1
        norms, ur, s, vt = svd
        keep = s > rank_rtol * s[0] if s.size and s[0] > 0 else np.zeros(s.shape, bool)
        # Convergence is judged on the undamped (Gauss–Newton) step: its size, and the
        # decrease it would achieve, ‖P_J r‖²; a heavily damped step is small whatever the
        # distance to the solution.
        size = float(np.linalg.norm(ur[keep] / s[keep]))
        best = float(np.sum(ur[keep] ** 2))
        near = best <= _NEAR_REL * rr + m * residual_rounding**2
        if size <= xtol:
            status = Status.STEP_TOLERANCE
            break
        if near and size >= previous:
            status = Status.ROUNDING_LEVEL
            break
        gain = np.zeros_like(s)
        gain[keep] = s[keep] / (s[keep] ** 2 + lam)
        step_scaled = -(vt.T @ (gain * ur))
        trial = move(x, step_scaled / norms)
        accepted = False
        if trial is not None:
            if lean:
                jac = None
            r_t, jac_t = fun(trial)
            nfev += 1
            njev += 1
            if _finite(r_t, jac_t):
                rr_t = float(r_t @ r_t)
                if rr_t <= (rr * (1.0 + _NEAR_SLACK) if near else rr):
                    x, r, jac, rr = trial, r_t, jac_t, rr_t
                    svd = _projected(jac, r)
                    previous = size if near else np.inf
                    lam = 0.0 if lam <= 1e-6 else lam / 10.0
                    accepted = True
            del r_t, jac_t  # a rejected trial's arrays go now, not at the next evaluation
        if not accepted:
            previous = np.inf
            lam = _LAMBDA_START if lam == 0.0 else lam * 10.0
            if lam > _LAMBDA_MAX:
                status = Status.DAMPING_LIMIT
                break
    if jac is None:
        jac = fun(x)[1]
        nfev += 1
        njev += 1
    return _result(x, r, jac, svd, status, nfev, njev, nit, rank_rtol)


def solve_equations(
    fun: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    x0: np.ndarray,
    *,
    rtol: float = 1e-12,
    max_iter: int = 50,
) -> LeastSquaresResult:
    """Solve a square system of equations ``r(x) = 0`` by Newton's method on the core.

    Parameters
    ----------
    fun : callable
        ``fun(x) -> (r (n,), J (n, n))``: the equations and their Jacobian.
    x0 : (n,) ndarray
        Starting point.
    rtol : float
        Relative tolerance of the step: stop (status 1) when the scaled step ``‖D Δx‖`` is
        below ``rtol·s``, with ``s = max_i Σ_j |J_ij(x0)|·max(|x0_j|, 1)`` the size of the
        terms of the linearised equations at ``x0`` (units of ``r``).
    max_iter : int
        Iteration limit (status 0).

    Returns
    -------
    LeastSquaresResult
        Never raises for a failed iteration: read ``status``/``success``; ``residuals``
        are ``r`` at ``x``.

    Notes
    -----
    For a square non-singular ``J`` the Gauss–Newton step of :func:`least_squares`,
    ``−J⁺ r``, is Newton's step ``−J⁻¹ r``; the Levenberg–Marquardt safeguard damps only
    a step that would increase ``‖r‖`` (a globalised Newton method, Dennis and Schnabel
    1996, §6.4).  The rounding unit of one equation is taken as ``ε·s`` (ε the machine
    epsilon), so that near the root the iteration also stops when its steps stop
    contracting (status 2).  A Jacobian singular at ``x0`` stops at once (status -3).

    References
    ----------
    J. E. Dennis and R. B. Schnabel, *Numerical Methods for Unconstrained Optimization
    and Nonlinear Equations*, SIAM, 1996, ch. 5 and §6.4.

    Examples
    --------
    The root of ``x² − 2`` from ``x0 = 1``:

    >>> res = solve_equations(lambda x: (x**2 - 2.0, np.diag(2.0 * x)), np.array([1.0]))
    >>> res.success, float(res.x[0]) == float(np.sqrt(2.0))
    (True, True)
    """
    x0 = np.asarray(x0, dtype=float)
    first = [fun(x0)]  # serves the scale and the first iteration of the core
    scale = float(np.max(np.abs(first[0][1]) @ np.maximum(np.abs(x0), 1.0), initial=0.0))
    scale = scale if np.isfinite(scale) and scale > 0 else 1.0
    return least_squares(
        lambda x: first.pop() if first else fun(x),
        x0,
        xtol=rtol * scale,
        max_iter=max_iter,
        residual_rounding=np.finfo(float).eps * scale,
        require_full_rank=True,
    )


def _rank(s: np.ndarray, rtol: float, n: int) -> int:
    if s.size == 0 or s[0] <= 0:
        return 0
    return int(np.sum(s > rtol * s[0])) if n else 0


def _result(x, r, jac, svd, status, nfev, njev, nit, rank_rtol) -> LeastSquaresResult:
    n = jac.shape[1]
    if svd is None:
        norms, s, vt = np.ones(n), np.zeros(min(jac.shape)), np.zeros((min(jac.shape), n))
    else:
        norms, _, s, vt = svd
    rank = _rank(s, rank_rtol, n)
    condition = float(s[0] / s[-1]) if rank == n and n > 0 else float("inf")
    return LeastSquaresResult(
        x=x,
        cost=0.5 * float(r @ r) if _finite(r) else float("nan"),
        residuals=r,
        jacobian=jac,
        column_norms=norms,
        singular_values=s,
        right_singular_vectors=vt,
        rank=rank,
        condition=condition,
        nfev=nfev,
        njev=njev,
        nit=nit,
        status=int(status),
    )


# ---------------------------------------------------------------------------------------
# Batched forms


@dataclass(frozen=True, eq=False)
class BatchLeastSquaresResult:
    """Result of :func:`least_squares_batch` or :func:`chord_batch` for K problems.

    Attributes
    ----------
    x : (K, n) ndarray
    cost : (K,) ndarray
        ``½‖r‖²`` of each problem at its ``x``.
    status : (K,) ndarray of int
        :class:`Status` code of each problem.
    nit : (K,) ndarray of int
        Iterations of each problem.
    nfev : int
        Batched evaluations (each covers the problems still iterating).
    """

    x: np.ndarray
    cost: np.ndarray
    status: np.ndarray
    nit: np.ndarray
    nfev: int

    @property
    def success(self) -> np.ndarray:
        """(K,) bool: converged problems."""
        return self.status > 0

    @property
    def message(self) -> str:
        """How many converged, and the commonest failure."""
        bad = self.status[self.status <= 0]
        if bad.size == 0:
            return f"all {self.status.size} problems converged"
        codes, counts = np.unique(bad, return_counts=True)
        worst = int(codes[np.argmax(counts)])
        return (
            f"{bad.size} of {self.status.size} problems did not converge "
            f"(most often: {_message(worst)})"
        )


#: Up to this order, stacked systems are factorised by the Cholesky recurrences written out
#: over the indices with vector operations over the stack, which beats LAPACK's
#: per-matrix call overhead for tiny matrices (spheres: 4×4); larger ones go to LAPACK.
_SMALL_ORDER = 6


def cholesky_solve(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solve a stack of symmetric positive-definite systems ``a[k] x[k] = b[k]``.

    Parameters
    ----------
    a : (K, n, n) ndarray
        Symmetric positive-definite matrices (only the lower triangle is read).
    b : (K, n) ndarray
        Right-hand sides.

    Returns
    -------
    x : (K, n) ndarray
        The solutions ``x = L⁻ᵀ L⁻¹ b`` with ``a = L Lᵀ``; NaN for a system whose
        factorisation fails (not positive definite).
    ok : (K,) ndarray of bool
        Whether each system was solved (a finite solution).

    Notes
    -----
    The Cholesky factorisation ``a = L Lᵀ`` and the two triangular solves ``L y = b``,
    ``Lᵀ x = y`` (Björck 1996, §2.2).  Up to order :data:`_SMALL_ORDER` the recurrences
    are written out over the indices with vector operations over the stack (faster than
    LAPACK's per-matrix overhead for tiny systems); larger orders go to LAPACK.  This is
    the solver of the damped normal equations of :func:`least_squares_batch`; batched
    element fits use it for their linear starting points.

    References
    ----------
    Å. Björck, *Numerical Methods for Least Squares Problems*, SIAM, 1996, §2.2.

    Examples
    --------
    >>> a = np.array([[[4.0, 2.0], [2.0, 3.0]], [[1.0, 2.0], [2.0, 1.0]]])
    >>> x, ok = cholesky_solve(a, np.array([[6.0, 5.0], [1.0, 1.0]]))
    >>> np.round(x[0], 12).tolist(), ok.tolist()
    ([1.0, 1.0], [True, False])
    """
    k, n = b.shape
    if n <= _SMALL_ORDER:
        chol = np.zeros((n, n, k))
        y = np.empty((n, k))
        x = np.empty((n, k))
        with np.errstate(invalid="ignore", divide="ignore"):
            for j in range(n):
                diag = a[:, j, j] - sum(chol[j, m] ** 2 for m in range(j))
                chol[j, j] = np.sqrt(np.where(diag > 0, diag, np.nan))
                for i in range(j + 1, n):
                    off = a[:, i, j] - sum(chol[i, m] * chol[j, m] for m in range(j))
                    chol[i, j] = off / chol[j, j]
            for i in range(n):
                y[i] = (b[:, i] - sum(chol[i, m] * y[m] for m in range(i))) / chol[i, i]
            for i in reversed(range(n)):
                x[i] = (y[i] - sum(chol[m, i] * x[m] for m in range(i + 1, n))) / chol[i, i]
        x = x.T
        return x, np.all(np.isfinite(x), axis=1)
    x = np.full(b.shape, np.nan)
    ok = np.ones(k, dtype=bool)
    try:
        low = np.linalg.cholesky(a)
    except np.linalg.LinAlgError:
        # rare: solve one by one to find the singular systems
        for i in range(k):
            try:
                low_i = np.linalg.cholesky(a[i])
            except np.linalg.LinAlgError:
                ok[i] = False
                continue
            x[i] = np.linalg.solve(low_i.T, np.linalg.solve(low_i, b[i]))
        return x, ok
    y = np.linalg.solve(low, b[..., None])
    x = np.linalg.solve(np.swapaxes(low, -1, -2), y)[..., 0]
    return x, np.all(np.isfinite(x), axis=1)


def least_squares_batch(
    normal_equations: Callable,
    x0: np.ndarray,
    *,
    retract: Callable | None = None,
    xtol: float = 0.0,
    max_iter: int = 100,
    residual_rounding=0.0,
) -> BatchLeastSquaresResult:
    """K independent small problems, each by Gauss–Newton with a Levenberg–Marquardt safeguard.

    Parameters
    ----------
    normal_equations : callable
        ``normal_equations(X (k, n), index (k,)) -> (A (k, n, n), g (k, n), rr (k,), m)``:
        ``A = JᵀJ``, ``g = Jᵀr``, ``rr = rᵀr`` at the k points, for the problems ``index``,
        and the number m of residuals per problem.
    x0 : (K, n) ndarray
    retract : callable, optional
        ``retract(X (k, n), steps (k, n), index) -> (X_new (k, n), valid (k,))``;
        ``X + steps`` (all valid) by default.
    xtol : float or (K,) ndarray
        Tolerance on the scaled step ``‖D Δx‖``, ``D = sqrt(diag A)``.
    max_iter : int
    residual_rounding : float or (K,) ndarray
        Rounding unit of one residual of each problem (rounding-level stop).

    Returns
    -------
    BatchLeastSquaresResult

    Notes
    -----
    The same iteration as :func:`least_squares`, written on the normal equations in
    scaled coordinates ``A_s = D⁻¹AD⁻¹`` (unit diagonal): ``(A_s + λI) δ_s = −D⁻¹g``,
    Cholesky-factorised for all problems at once.  A problem whose system is singular
    stops with status -2.  Only the problems still iterating are evaluated.
    """
    x = np.array(x0, dtype=float, copy=True)
    n_problems, n = x.shape
    rounding = np.broadcast_to(np.asarray(residual_rounding, dtype=float), (n_problems,))
    step_tol = np.broadcast_to(np.asarray(xtol, dtype=float), (n_problems,))
    move = retract if retract is not None else (lambda xs, st, idx: (xs + st, None))
    status = np.full(n_problems, int(Status.ITERATION_LIMIT), dtype=np.int8)
    nit = np.zeros(n_problems, dtype=int)
    lam = np.zeros(n_problems)
    previous = np.full(n_problems, np.inf)
    everyone = np.arange(n_problems)
    a, g, rr, m = normal_equations(x, everyone)
    nfev = 1
    active = everyone
    eye = np.eye(n)
    for _ in range(max_iter):
        if active.size == 0:
            break
        xa, aa, ga, rra, lama = x[active], a[active], g[active], rr[active], lam[active]
        d = np.sqrt(np.maximum(np.einsum("kii->ki", aa), 0.0))
        d = np.where(d > 0, d, 1.0)
        scaled = aa / (d[:, :, None] * d[:, None, :])
        damped = scaled + lama[:, None, None] * eye
        gs = ga / d
        step_s, ok = cholesky_solve(damped, -gs)
        step_s[~ok] = 0.0
        size = np.linalg.norm(step_s, axis=1)
        # decrease of an undamped step, −δᵀg_s = ‖P_J r‖²; damped steps are judged by the
        # cost alone (a small damped step says nothing about nearness to the solution)
        predicted = -np.einsum("ki,ki->k", step_s, gs)
        near = (lama == 0.0) & (predicted <= _NEAR_REL * rra + m * rounding[active] ** 2)
        nit[active] += 1
        # convergence is judged on undamped steps only (as in least_squares)
        done_xtol = (size <= step_tol[active]) & ok & (lama == 0.0)
        done_round = near & (size >= previous[active]) & ok & ~done_xtol
        status[active[done_xtol]] = Status.STEP_TOLERANCE
        status[active[done_round]] = Status.ROUNDING_LEVEL
        status[active[~ok]] = Status.NOT_FINITE
        pending = ok & ~done_xtol & ~done_round
        idx = active[pending]
        if idx.size:
            trial, valid = move(xa[pending], step_s[pending] / d[pending], idx)
            valid = np.ones(idx.size, bool) if valid is None else np.asarray(valid, bool)
            a_t, g_t, rr_t, _ = normal_equations(trial, idx)
            nfev += 1
            limit = np.where(near[pending], rra[pending] * (1.0 + _NEAR_SLACK), rra[pending])
            better = valid & np.isfinite(rr_t) & (rr_t <= limit)
            moved = idx[better]
            x[moved], a[moved], g[moved], rr[moved] = (
                trial[better],
                a_t[better],
                g_t[better],
                rr_t[better],
            )
            previous[moved] = np.where(near[pending][better], size[pending][better], np.inf)
            lam[moved] = np.where(lam[moved] <= 1e-6, 0.0, lam[moved] / 10.0)
            worse = idx[~better]
            previous[worse] = np.inf
            lam[worse] = np.where(lam[worse] == 0.0, _LAMBDA_START, lam[worse] * 10.0)
            gave_up = worse[lam[worse] > _LAMBDA_MAX]
            status[gave_up] = Status.DAMPING_LIMIT
            idx = idx[lam[idx] <= _LAMBDA_MAX]
        active = idx
    return BatchLeastSquaresResult(x, 0.5 * rr, status, nit, nfev)


def chord_batch(
    residuals: Callable[[np.ndarray, np.ndarray], np.ndarray],
    x0: np.ndarray,
    jacobian: np.ndarray,
    *,
    xtol: float = 1e-8,
    max_iter: int = 20,
    rank_rtol: float = 1e-10,
    apply_final_step: bool = False,
) -> BatchLeastSquaresResult:
    """K perturbed copies of one problem, by Gauss–Newton steps with one shared Jacobian.

    Parameters
    ----------
    residuals : callable
        ``residuals(X (k, n), index (k,)) -> R (k, m)``: exact residuals of the problems
        ``index`` at the points X.
    x0 : (K, n) ndarray
        Starting points (usually the solution of the unperturbed problem, repeated).
    jacobian : (m, n) ndarray
        The Jacobian at the unperturbed solution, factorised once.
    xtol : float
        Tolerance on the scaled step ``‖D Δx‖`` of each problem (D: the column norms of
        ``jacobian``).
    max_iter : int
    rank_rtol : float
        As in :func:`least_squares` (minimum-norm steps when rank deficient).
    apply_final_step : bool
        Also apply the step that met ``xtol`` (it needs no further evaluation): the
        remaining error is then about the contraction rate times ``xtol`` instead of
        ``xtol``, so a loose ``xtol`` saves an evaluation of every problem.  ``cost`` is
        then that of the last evaluated point, before the final step.

    Returns
    -------
    BatchLeastSquaresResult

    Notes
    -----
    The chord (simplified Gauss–Newton) iteration ``x ← x − J₀⁺ r(x)`` converges linearly
    with rate ``‖I − J₀⁺J(x)‖``, which for Monte Carlo perturbations of the size of the
    measurement noise is of the order of the relative change of the Jacobian (≈1e-6 for
    µm-level noise on a machine calibration): one or two steps reach ``xtol``.  Its fixed
    point solves ``J₀ᵀ r(x) = 0`` rather than ``J(x)ᵀ r(x) = 0``; the two differ by
    ``O(‖J(x) − J₀‖·‖r‖)``, second order in the perturbation — callers can measure it on a
    subset with :func:`least_squares`.  A step that grows instead of contracting marks a
    perturbation outside the chord's reach: status -1.
    """
    x = np.array(x0, dtype=float, copy=True)
    n_problems = x.shape[0]
    norms, u, s, vt = _scaled_svd(np.asarray(jacobian, dtype=float))
    keep = s > rank_rtol * s[0]
    # scaled step = -P r with P = V S⁻¹ Uᵀ over the kept singular values
    p = (vt[keep].T / s[keep]) @ u[:, keep].T  # (n, m)
    status = np.full(n_problems, int(Status.ITERATION_LIMIT), dtype=np.int8)
    nit = np.zeros(n_problems, dtype=int)
    cost = np.full(n_problems, np.nan)
    previous = np.full(n_problems, np.inf)
    active = np.arange(n_problems)
    nfev = 0
    for _ in range(max_iter + 1):
        if active.size == 0:
            break
        r = residuals(x[active], active)
        nfev += 1
        finite = np.all(np.isfinite(r), axis=1)
        cost[active] = 0.5 * np.einsum("km,km->k", r, r)
        status[active[~finite]] = Status.NOT_FINITE
        step_s = -(r[finite] @ p.T)  # (k, n)
        size = np.linalg.norm(step_s, axis=1)
        live = active[finite]
        done = size <= xtol
        status[live[done]] = Status.STEP_TOLERANCE
        if apply_final_step:
            x[live[done]] += step_s[done] / norms
        diverging = ~done & (size >= previous[live])
        status[live[diverging]] = Status.DAMPING_LIMIT
        go = ~done & ~diverging & (nit[live] < max_iter)
        idx = live[go]
        x[idx] += step_s[go] / norms
        nit[idx] += 1
        previous[idx] = size[go]
        active = idx
    return BatchLeastSquaresResult(x, cost, status, nit, nfev)
