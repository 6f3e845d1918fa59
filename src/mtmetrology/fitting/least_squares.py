"""Orthogonal-distance least-squares fits of geometric elements.

Every fit minimises the sum of squared orthogonal distances ``Σ d_i(θ)²`` of the points
to the element (ISO 10360-6 / NIST algorithm-testing definition of the least-squares
element; Forbes, "Least-squares best fit geometric elements", NPL DITC 140/89;
Shakarji, J. Res. NIST 103 (1998) 633).  Lines and planes are solved exactly by the SVD of
the centred points (total least squares).  Circles, spheres, cylinders and cones start
from algebraic fits (the "hyper" fit of Al-Sharadqah and Chernov for circles and spheres,
a linear cone/cylinder model about candidate axes) and are refined by Gauss–Newton with a
Levenberg–Marquardt safeguard, on analytic Jacobians, in Forbes' local frames (the
current axis turned to z, so the tilt parameters are always well defined).  All work is
done in coordinates centred on the data centroid, so data far from the origin lose no
accuracy.

Parameter Jacobians
-------------------
Each :class:`FitResult` carries ``parameter_jacobian`` = dθ/dP, shape
``(n_params, n_points, dim)``, for GUF propagation.  It is the first-order
implicit-function form of the normal equations ``J(β)ᵀ d(β, P) = 0``::

    dβ/dP = −(JᵀJ)⁻¹ Jᵀ ∂d/∂P                     (local parameters β)
    dθ/dP = (∂θ/∂β) dβ/dP + ∂θ/∂P|_β              (reported parameters θ)

It drops the terms ``Σ d_i ∂²d_i/∂β²`` and ``Σ d_i ∂²d_i/∂β∂P``, so it is exact for
a zero-residual fit and has a relative error of the order of (form error / element
size) otherwise, the usual GUF linearisation.  The second term carries the dependence of
the reported reference point (foot of the centroid) on the centroid.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.linalg
from scipy.spatial import cKDTree

from mtmetrology.fitting.elements import Circle, Cone, Cylinder, Element, Line, Plane, Sphere

__all__ = [
    "FitError",
    "FitResult",
    "fit_circle",
    "fit_cone",
    "fit_cylinder",
    "fit_line",
    "fit_plane",
    "fit_sphere",
]

# A singular value below this fraction of the largest marks a degenerate point set.
_DEGENERATE = 1e-10
# Gauss–Newton stops when the step is below this fraction of the data size.
_STEP_TOL = 1e-13
# Steps whose predicted relative cost decrease is below this are accepted whatever the
# (rounding-level) change of the cost; the iteration ends when they stop contracting.
_NEAR_REL = 1e-10
_EPS = float(np.finfo(float).eps)
_MAX_ITER = 200


class FitError(ValueError):
    """A point set from which the requested element cannot be fitted."""


@dataclass(frozen=True, eq=False)
class FitResult:
    """Result of an orthogonal-distance least-squares fit.

    Attributes
    ----------
    element : Element
        The fitted element (mm, rad).
    residuals : (n,) array, mm
        Signed orthogonal distances of the points to the element.
    rms : float, mm
        Root mean square of the residuals.
    form_error : float, mm
        Peak-to-valley ``max − min`` of the residuals (for a 3-D line, whose distances are
        unsigned, ``2·max``: the diameter of the coaxial cylinder containing the points).
    iterations : int
        Gauss–Newton iterations (0 for the closed-form SVD fits).
    converged : bool
    message : str
    parameter_jacobian : (n_params, n, dim) array
        dθ/dP of ``element.parameters`` with respect to the point coordinates
        (first-order implicit-function form, see the module notes).
    """

    element: Element
    residuals: np.ndarray = field(repr=False)
    rms: float
    form_error: float
    iterations: int
    converged: bool
    message: str
    parameter_jacobian: np.ndarray = field(repr=False)
    # Residual sensitivities: d_i depends on its own point through direct (n, dim) and on
    # the local parameters through local (n, p) whose derivatives are local_jacobian.
    _direct: np.ndarray = field(repr=False)
    _local: np.ndarray = field(repr=False)
    _local_jacobian: np.ndarray = field(repr=False)

    @property
    def parameters(self) -> np.ndarray:
        return self.element.parameters

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return self.element.parameter_names

    def parameter_covariance(self, sigma: float) -> np.ndarray:
        """Covariance of the parameters for independent isotropic point noise.

        Parameters
        ----------
        sigma : float, mm
            Standard deviation of every point coordinate.

        Returns
        -------
        (n_params, n_params) array
            ``σ² G Gᵀ`` with ``G`` the parameter Jacobian flattened to
            ``(n_params, n·dim)`` (GUM 5.1.2 in matrix form, JCGM 102:2011, 6.2.1.3).
        """
        s = float(sigma)
        if not np.isfinite(s) or s < 0:
            raise ValueError(f"sigma must be a non-negative finite number, got {sigma!r}")
        g = self.parameter_jacobian.reshape(self.parameter_jacobian.shape[0], -1)
        return s * s * (g @ g.T)

    def residual_jacobian(self) -> np.ndarray:
        """d(residual_i)/d(P_j), shape ``(n, n, dim)`` (first-order form).

        Form errors (max − min residual) differentiate through it.
        """
        out = np.einsum("ip,pjd->ijd", self._local, self._local_jacobian)
        idx = np.arange(out.shape[0])
        out[idx, idx, :] += self._direct
        return out


# ----------------------------------------------------------------------------- helpers


def _check_points(points: object, kind: str, dims: tuple[int, ...], min_points: int) -> np.ndarray:
    """Validate a point array at the public boundary; return a float (n, d) copy."""
    try:
        arr = np.array(points, dtype=float)
    except (TypeError, ValueError) as exc:
        raise FitError(f"{kind}: points must be a numeric (n, d) array ({exc})") from exc
    if arr.ndim != 2 or arr.shape[1] not in dims:
        want = " or ".join(f"(n, {d})" for d in dims)
        raise FitError(f"{kind}: points must have shape {want}, got {arr.shape}")
    bad = ~np.all(np.isfinite(arr), axis=1)
    if bad.any():
        rows = np.flatnonzero(bad)
        raise FitError(
            f"{kind}: {rows.size} point(s) contain NaN or inf (first at row {int(rows[0])})"
        )
    if arr.shape[0] < min_points:
        raise FitError(
            f"{kind}: {arr.shape[0]} points are fewer than the {min_points} needed "
            f"to determine the element"
        )
    return arr


def _singular_values(x: np.ndarray) -> np.ndarray:
    return np.linalg.svd(x, compute_uv=False)


def _require_spread(kind: str, centred: np.ndarray, rank: int, what: str, hint: str = "") -> None:
    """Raise unless the centred points span at least ``rank`` dimensions."""
    s = _singular_values(centred)
    if s[0] == 0.0 or s[rank - 1] <= _DEGENERATE * s[0]:
        rel = 0.0 if s[0] == 0.0 else s[rank - 1] / s[0]
        raise FitError(
            f"{kind}: the {centred.shape[0]} points are {what} (relative singular value "
            f"{rel:.1e} of the centred points){hint}"
        )


def _canonical(v: np.ndarray) -> np.ndarray:
    """Sign convention for undirected axes and normals: largest component positive."""
    return v if v[np.argmax(np.abs(v))] > 0 else -v


def _perp_basis(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors completing ``a`` to a right-handed orthonormal frame.

    A deterministic function of ``a``: evaluation and update use the same frame.
    """
    helper = np.eye(3)[int(np.argmin(np.abs(a)))]
    e1 = np.cross(a, helper)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1)


def _local_to_points(j: np.ndarray, g: np.ndarray) -> np.ndarray:
    """dβ/dP = −J⁺ ∂d/∂P for residuals grouped per point.

    j : (n, q, p) Jacobian of the q residuals of each point w.r.t. local parameters β.
    g : (n, q, dim) derivative of each residual w.r.t. its own point.
    Returns (p, n, dim).
    """
    n, q, p = j.shape
    a = -np.linalg.pinv(j.reshape(n * q, p)).reshape(p, n, q)
    return np.einsum("pnq,nqd->pnd", a, g)


def _check_conditioning(kind: str, j: np.ndarray, names: str) -> None:
    s = _singular_values(j)
    if s[-1] <= 1e-12 * s[0]:
        raise FitError(
            f"{kind}: the parameters ({names}) are not determined by these points "
            f"(Jacobian condition number {s[0] / max(s[-1], 1e-300):.1e})"
        )


@dataclass
class _Solve:
    state: Any
    iterations: int
    converged: bool
    cost: float


def _gauss_newton(
    evaluate: Callable[[Any], tuple[np.ndarray, np.ndarray]],
    retract: Callable[[Any, np.ndarray], Any],
    state: Any,
    scale: float,
) -> _Solve:
    """Gauss–Newton with a Levenberg–Marquardt safeguard.

    ``evaluate(state) -> (d (m,), J (m, p))``; ``retract(state, δ)`` applies a step in the
    local parameters and returns the new state (None if it leaves the domain).  A pure
    Gauss–Newton step is tried first; if it does not lower the cost, the damped step
    ``(JᵀJ + λ diag(JᵀJ)) δ = −Jᵀd`` is used with growing λ (Moré's scaling), and λ is
    relaxed again after each success.
    """
    d, jac = evaluate(state)
    cost = float(d @ d)
    lam = 0.0
    previous = np.inf  # last accepted step size in the near-converged regime
    for it in range(1, _MAX_ITER + 1):
        if lam == 0.0:
            step = np.linalg.lstsq(jac, -d, rcond=None)[0]
        else:
            dscale = np.sqrt(lam) * np.maximum(np.linalg.norm(jac, axis=0), 1e-300)
            aug = np.vstack([jac, np.diag(dscale)])
            rhs = np.concatenate([-d, np.zeros(jac.shape[1])])
            step = np.linalg.lstsq(aug, rhs, rcond=None)[0]
        size = float(np.linalg.norm(step))
        # Near the solution the predicted decrease ‖Jδ‖² is below the rounding noise of
        # the cost, so the cost can no longer judge steps.
        predicted = float(np.sum((jac @ step) ** 2))
        near = predicted <= _NEAR_REL * cost + d.size * (_EPS * scale) ** 2
        # Converged: a negligible step, or near the solution steps stopped contracting
        # (they are rounding noise).
        if size <= _STEP_TOL * scale or (near and size >= previous):
            return _Solve(state, it, True, cost)
        trial = retract(state, step)
        if trial is not None:
            d_t, jac_t = evaluate(trial)
            cost_t = float(d_t @ d_t)
            # Near the solution the cost changes by less than its rounding error, so the
            # step sizes decide convergence; far from it the cost must not increase.
            if cost_t <= (cost * (1.0 + 1e-9) if near else cost):
                state, d, jac, cost = trial, d_t, jac_t, cost_t
                previous = size if near else np.inf
                lam = 0.0 if lam <= 1e-6 else lam / 10.0
                continue
        previous = np.inf
        lam = 1e-3 if lam == 0.0 else lam * 10.0
        if lam > 1e12:
            return _Solve(state, it, False, cost)
    return _Solve(state, _MAX_ITER, False, cost)


def _better(solve: _Solve, best: _Solve | None) -> bool:
    """Whether a fit from another starting value beats the best so far: converged first,
    then a cost lower beyond rounding (ties keep the earlier, preferred candidate)."""
    if best is None or (solve.converged and not best.converged):
        return True
    return solve.converged == best.converged and solve.cost < best.cost * (1.0 - 1e-9)


def _message(kind: str, solve: _Solve, rms: float) -> str:
    if solve.converged:
        return f"{kind}: converged in {solve.iterations} iterations (rms {rms:.3g} mm)"
    return (
        f"{kind}: not converged after {solve.iterations} iterations "
        f"(rms {rms:.3g} mm); the result is the best point reached"
    )


def _result(
    element: Element,
    residuals: np.ndarray,
    iterations: int,
    converged: bool,
    message: str,
    jacobian: np.ndarray,
    direct: np.ndarray,
    local: np.ndarray,
    local_jacobian: np.ndarray,
    form_error: float | None = None,
) -> FitResult:
    rms = float(np.sqrt(np.mean(residuals**2)))
    pv = float(residuals.max() - residuals.min()) if form_error is None else form_error
    return FitResult(
        element=element,
        residuals=residuals,
        rms=rms,
        form_error=pv,
        iterations=iterations,
        converged=converged,
        message=message,
        parameter_jacobian=jacobian,
        _direct=direct,
        _local=local,
        _local_jacobian=local_jacobian,
    )


def _centred(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    centroid = points.mean(axis=0)
    x = points - centroid
    scale = float(np.sqrt(np.mean(np.sum(x * x, axis=1))))
    return x, centroid, scale


# ------------------------------------------------------------------------- line, plane


def fit_line(points: object) -> FitResult:
    """Least-squares (total least squares) line through 2-D or 3-D points.

    Parameters
    ----------
    points : (n, 2) or (n, 3) array, mm
        n ≥ 2 points, not all coincident.

    Returns
    -------
    FitResult
        ``element`` is a :class:`Line` through the centroid (its foot), direction with its
        largest component positive.  Residuals are signed in 2-D, non-negative in 3-D.

    Raises
    ------
    FitError
        Wrong shape, NaN/inf, fewer than 2 points, or coincident points.

    Notes
    -----
    The direction is the right singular vector of the largest singular value of the
    centred points: it minimises ``Σ ‖(p_i − c̄) − ((p_i − c̄)·a) a‖²`` exactly
    (Forbes, NPL DITC 140/89, §4.2; Shakarji 1998, §3.1).
    """
    p = _check_points(points, "line", (2, 3), 2)
    x, centroid, _ = _centred(p)
    n, dim = p.shape
    s, vt = np.linalg.svd(x, full_matrices=False)[1:]
    if s[0] <= _DEGENERATE * max(float(np.abs(p).max()), 1.0):
        raise FitError(f"line: the {n} points coincide; a line needs two distinct points")
    a = _canonical(vt[0])
    line = Line(centroid, a)
    along = x @ a  # (n,) axial coordinates
    if dim == 2:
        nrm = line.normal
        y = x @ nrm  # (n,) signed distances
        # Local parameters β = (δy, δa): point += δy·nrm, direction += δa·nrm.
        j = np.stack([-np.ones(n), -along], axis=1)[:, None, :]  # (n, 1, 2)
        g = np.broadcast_to(nrm, (n, 1, 2))
        dbeta = _local_to_points(j, g)  # (2, n, 2)
        t = np.zeros((4, 2))
        t[0:2, 0] = nrm
        t[2:4, 1] = nrm
        direct = np.zeros((4, n, 2))
        direct[0:2] = (np.outer(a, a) / n)[:, None, :]
        jac = np.einsum("tb,bnd->tnd", t, dbeta) + direct
        return _result(
            line, y, 0, True, "line: closed-form SVD fit", jac, g[:, 0, :], j[:, 0, :], dbeta
        )
    e1, e2 = vt[1], vt[2]
    u, v = x @ e1, x @ e2  # (n,) components of the perpendicular offsets
    rho = np.hypot(u, v)
    # Local parameters β = (δx, δy, δa, δb): point += δx e1 + δy e2, a += δa e1 + δb e2.
    zeros = np.zeros(n)
    j = np.stack(
        [
            np.stack([-np.ones(n), zeros, -along, zeros], axis=1),
            np.stack([zeros, -np.ones(n), zeros, -along], axis=1),
        ],
        axis=1,
    )  # (n, 2, 4)
    g = np.broadcast_to(np.stack([e1, e2]), (n, 2, 3))
    dbeta = _local_to_points(j, g)  # (4, n, 3)
    t = np.zeros((6, 4))
    t[0:3, 0], t[0:3, 1], t[3:6, 2], t[3:6, 3] = e1, e2, e1, e2
    direct = np.zeros((6, n, 3))
    direct[0:3] = (np.outer(a, a) / n)[:, None, :]
    jac = np.einsum("tb,bnd->tnd", t, dbeta) + direct
    # The distance ρ = ‖(u, v)‖ differentiates along the unit offset (u, v)/ρ.
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(rho[:, None] > 0, np.stack([u, v], axis=1) / rho[:, None], 0.0)
    return _result(
        line,
        rho,
        0,
        True,
        "line: closed-form SVD fit",
        jac,
        np.einsum("nq,nqd->nd", w, g),
        np.einsum("nq,nqp->np", w, j),
        dbeta,
        form_error=float(2.0 * rho.max()),
    )


def _plane_core(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """SVD frame (e1, e2, n) of centred points; n canonical, (e1, e2, n) right-handed."""
    vt = np.linalg.svd(x, full_matrices=False)[2]
    nrm = _canonical(vt[2])
    e1 = vt[0]
    return e1, np.cross(nrm, e1), nrm


def _plane_local(x: np.ndarray, e1: np.ndarray, e2: np.ndarray, nrm: np.ndarray):
    """Local plane Jacobian: β = (δz, δa, δb), point += δz n, n −= δa e1 + δb e2."""
    n = x.shape[0]
    j = np.stack([-np.ones(n), -(x @ e1), -(x @ e2)], axis=1)[:, None, :]  # (n, 1, 3)
    g = np.broadcast_to(nrm, (n, 1, 3))
    return j, g, _local_to_points(j, g)  # dβ/dP (3, n, 3)


def fit_plane(points: object) -> FitResult:
    """Least-squares (total least squares) plane.

    Parameters
    ----------
    points : (n, 3) array, mm
        n ≥ 3 points, not collinear.

    Returns
    -------
    FitResult
        ``element`` is a :class:`Plane` through the centroid; ``form_error`` is the
        least-squares flatness (max − min signed distance).

    Raises
    ------
    FitError
        Wrong shape, NaN/inf, fewer than 3 points, collinear points.

    Notes
    -----
    The normal is the right singular vector of the smallest singular value of the centred
    points (Forbes, NPL DITC 140/89, §4.3).  Digest 001-003 §B2.2 warns that the paper's
    algebraic form ``p·x + 1 = 0`` is singular for planes through the origin; this
    orthogonal fit has no such restriction.
    """
    p = _check_points(points, "plane", (3,), 3)
    x, centroid, _ = _centred(p)
    n = p.shape[0]
    _require_spread("plane", x, 2, "collinear")
    e1, e2, nrm = _plane_core(x)
    j, g, dbeta = _plane_local(x, e1, e2, nrm)
    t = np.zeros((6, 3))
    t[0:3, 0] = nrm
    t[3:6, 1], t[3:6, 2] = -e1, -e2
    direct = np.zeros((6, n, 3))
    direct[0:3] = ((np.eye(3) - np.outer(nrm, nrm)) / n)[:, None, :]
    jac = np.einsum("tb,bnd->tnd", t, dbeta) + direct
    return _result(
        Plane(centroid, nrm),
        x @ nrm,
        0,
        True,
        "plane: closed-form SVD fit",
        jac,
        g[:, 0, :],
        j[:, 0, :],
        dbeta,
    )


# ---------------------------------------------------------------- circle and sphere


def _hyper_fit(x: np.ndarray) -> tuple[np.ndarray, float]:
    """Algebraic "hyper" circle/sphere fit of centred points x (n, d).

    Minimises ``AᵀMA`` subject to ``AᵀNA = 1`` for ``A0‖x‖² + b·x + c = 0`` with the
    hyper constraint ``N = 2 N_Taubin − N_Pratt`` (Al-Sharadqah & Chernov, Electron. J.
    Stat. 3 (2009) 886), which has no essential bias; used only as a starting value.
    """
    n, d = x.shape
    scale = float(np.sqrt(np.mean(np.sum(x * x, axis=1))))
    y = x / scale
    z = np.sum(y * y, axis=1)
    zmat = np.column_stack([z, y, np.ones(n)])  # (n, d + 2)
    m = zmat.T @ zmat / n
    nmat = np.zeros((d + 2, d + 2))
    nmat[0, 0] = 8.0 * z.mean()
    nmat[0, 1 : d + 1] = nmat[1 : d + 1, 0] = 4.0 * y.mean(axis=0)
    nmat[1 : d + 1, 1 : d + 1] = np.eye(d)
    nmat[0, d + 1] = nmat[d + 1, 0] = 2.0
    eta, vecs = scipy.linalg.eig(m, nmat)
    eta = np.real_if_close(eta, tol=1e6)
    ok = np.isfinite(eta) & (np.abs(np.imag(eta)) == 0)
    eta_r = np.real(eta)
    ok &= eta_r >= -1e-10 * np.max(np.abs(eta_r[ok])) if ok.any() else ok
    if not ok.any():
        raise FitError("no admissible algebraic circle/sphere")
    k = np.flatnonzero(ok)[np.argmin(eta_r[ok])]
    a = np.real(vecs[:, k])
    if abs(a[0]) <= 1e-14 * np.linalg.norm(a):
        raise FitError("the points lie on a line/plane: no finite circle/sphere")
    centre = -a[1 : d + 1] / (2.0 * a[0])
    r2 = float(centre @ centre - a[d + 1] / a[0])
    radius = float(np.sqrt(max(r2, 0.0)))
    if radius == 0.0:
        radius = float(np.mean(np.linalg.norm(y - centre, axis=1)))
    return centre * scale, radius * scale


def _fit_round(
    x: np.ndarray, scale: float, radius: float | None, kind: str
) -> tuple[np.ndarray, float, _Solve]:
    """Geometric circle/sphere fit of centred points (n, d); radius fixed if given."""
    try:
        c0, r0 = _hyper_fit(x)
    except FitError as exc:
        raise FitError(f"{kind}: {exc}") from exc
    d = x.shape[1]
    if radius is not None:
        r0 = radius

    def evaluate(state: tuple[np.ndarray, float]) -> tuple[np.ndarray, np.ndarray]:
        c, r = state
        v = x - c  # (n, d)
        rho = np.linalg.norm(v, axis=1)
        u = v / rho[:, None]
        if radius is None:
            return rho - r, np.column_stack([-u, -np.ones(len(rho))])
        return rho - r, -u

    def retract(state: tuple[np.ndarray, float], step: np.ndarray):
        c, r = state
        if radius is None:
            return (c + step[:d], r + step[d]) if r + step[d] > 0 else None
        return (c + step, r)

    solve = _gauss_newton(evaluate, retract, (c0, r0), scale)
    c, r = solve.state
    return c, r, solve


def _round_local(x: np.ndarray, c: np.ndarray, fixed_radius: bool):
    """Jacobian pieces of ‖p − c‖ − r: β = (δc, δr) or δc; returns j (n,1,p), g, dβ/dP."""
    v = x - c
    u = v / np.linalg.norm(v, axis=1)[:, None]  # (n, d) outward unit vectors
    j = -u if fixed_radius else np.column_stack([-u, -np.ones(len(u))])
    j = j[:, None, :]
    g = u[:, None, :]
    return j, g, _local_to_points(j, g)


def fit_sphere(points: object, radius: float | None = None) -> FitResult:
    """Least-squares sphere; with ``radius`` given, the centre only.

    Parameters
    ----------
    points : (n, 3) array, mm
        n ≥ 4 points, not coplanar (with a free radius the radius would be
        undetermined; with a known radius the centre has two mirror images).
    radius : float, mm, optional
        Known radius (e.g. the SAMBA master ball radius plus the effective tip radius,
        digest 000 §3.12 "ball centre from 5 points").  The fitted radius is then this
        value and its row of the parameter Jacobian is zero.

    Returns
    -------
    FitResult
        ``element`` is a :class:`Sphere`; ``form_error`` is the least-squares sphericity.

    Raises
    ------
    FitError
        Wrong shape, NaN/inf, too few points, coplanar points.

    Notes
    -----
    Minimises ``Σ (‖p_i − c‖ − r)²`` (digest 000 §3.12; Forbes §4.6) from the algebraic
    hyper fit.  Coplanar points leave the free radius undetermined and a known-radius
    centre ambiguous (two mirror images), so both raise.

    Examples
    --------
    >>> pts = [[10, 0, 0], [0, 10, 0], [-10, 0, 0], [0, -10, 0], [0, 0, 10]]
    >>> fit = fit_sphere(pts)
    >>> bool(np.allclose(fit.element.centre, 0.0, atol=1e-12)), round(fit.element.radius, 12)
    (True, 10.0)
    """
    fixed = radius is not None
    kind = "sphere (known radius)" if fixed else "sphere"
    p = _check_points(points, kind, (3,), 4)
    r_known = None
    if fixed:
        r_known = float(radius)  # type: ignore[arg-type]
        if not np.isfinite(r_known) or r_known <= 0:
            raise FitError(f"{kind}: radius must be a positive finite number, got {radius!r}")
    x, centroid, scale = _centred(p)
    hint = (
        "; the mirror-image centres cannot be told apart"
        if fixed
        else "; a sphere needs points off one plane (give the radius only if they are not)"
    )
    _require_spread(kind, x, 3, "coplanar", hint)
    c, r, solve = _fit_round(x, scale, r_known, kind)
    j, g, dbeta = _round_local(x, c, fixed)
    _check_conditioning(kind, j[:, 0, :], "centre" if fixed else "centre and radius")
    sphere = Sphere(c + centroid, r)
    jac = np.zeros((4, p.shape[0], 3))
    jac[: dbeta.shape[0]] = dbeta
    residuals = np.linalg.norm(x - c, axis=1) - r
    rms = float(np.sqrt(np.mean(residuals**2)))
    return _result(
        sphere,
        residuals,
        solve.iterations,
        solve.converged,
        _message(kind, solve, rms),
        jac,
        g[:, 0, :],
        j[:, 0, :],
        dbeta,
    )


def fit_circle(points: object, plane: Plane | None = None) -> FitResult:
    """Least-squares circle: in 2-D, or in 3-D within a plane (fitted first unless given).

    Parameters
    ----------
    points : (n, 2) or (n, 3) array, mm
        n ≥ 3 points, not collinear.
    plane : Plane, optional
        For 3-D points: the plane of the circle (e.g. the nominal plane of a ring gauge).
        If omitted, the least-squares plane of the points is used.

    Returns
    -------
    FitResult
        ``element`` is a :class:`Circle`; residuals are the radial deviations of the
        points' projections on the plane; ``form_error`` is the least-squares roundness.

    Raises
    ------
    FitError
        Wrong shape, NaN/inf, fewer than 3 points, collinear points.

    Notes
    -----
    Minimises ``Σ (ρ_i − r)²`` with ``ρ_i`` the in-plane distance of point i from the
    centre (digest 001-003 §B2.2 eq. 4; Forbes §4.5: plane first, then circle in it).
    For the 3-D fit without a given plane, the parameter Jacobian includes the
    dependence on the fitted plane (two-stage chain rule).

    Examples
    --------
    >>> fit = fit_circle([[31.75, 0], [0, 31.75], [-31.75, 0], [0, -31.75]])
    >>> round(2 * fit.element.radius, 12), fit.form_error < 1e-12
    (63.5, True)
    """
    p = _check_points(points, "circle", (2, 3), 3)
    x, centroid, scale = _centred(p)
    n, dim = p.shape
    if dim == 2:
        _require_spread("circle", x, 2, "collinear")
        c, r, solve = _fit_round(x, scale, None, "circle")
        j, g, dbeta = _round_local(x, c, False)
        _check_conditioning("circle", j[:, 0, :], "centre and radius")
        residuals = np.linalg.norm(x - c, axis=1) - r
        rms = float(np.sqrt(np.mean(residuals**2)))
        return _result(
            Circle(c + centroid, r),
            residuals,
            solve.iterations,
            solve.converged,
            _message("circle", solve, rms),
            dbeta,
            g[:, 0, :],
            j[:, 0, :],
            dbeta,
        )
    if plane is not None:
        if not isinstance(plane, Plane):
            raise FitError(f"circle: plane must be a Plane, got {type(plane).__name__}")
        nrm = plane.normal
        e1, e2 = _perp_basis(nrm)
        # Origin: the centroid's foot on the given plane.
        origin = centroid - ((centroid - plane.point) @ nrm) * nrm
        x = p - origin
    else:
        _require_spread("circle", x, 2, "collinear")
        e1, e2, nrm = _plane_core(x)
        origin = centroid
    uv = np.column_stack([x @ e1, x @ e2])  # (n, 2) in-plane coordinates
    _require_spread("circle", uv - uv.mean(axis=0), 2, "collinear in the circle's plane")
    uv_mean = uv.mean(axis=0)
    c2, r, solve = _fit_round(uv - uv_mean, scale, None, "circle")
    c2 = c2 + uv_mean
    jc, gc2, dbc = _round_local(uv, c2, False)  # local β_c = (δuc, δvc, δr)
    _check_conditioning("circle", jc[:, 0, :], "centre and radius")
    centre = origin + c2[0] * e1 + c2[1] * e2
    residuals = np.linalg.norm(uv - c2, axis=1) - r
    rms = float(np.sqrt(np.mean(residuals**2)))
    cu = gc2[:, 0, :]  # (n, 2) in-plane unit radial vectors
    g3 = cu[:, 0:1] * e1 + cu[:, 1:2] * e2  # (n, 3) direct derivative of ρ_i − r
    jc_flat = jc[:, 0, :]
    if plane is not None:
        dbeta = _local_to_points(jc, g3[:, None, :])  # (3, n, 3)
        t = np.zeros((7, 3))
        t[0:3, 0], t[0:3, 1], t[6, 2] = e1, e2, 1.0
        jac = np.einsum("tb,bnd->tnd", t, dbeta)
        local, local_jac = jc_flat, dbeta
    else:
        # Stage 1, plane β_p = (δz, δa, δb); stage 2, circle in the tilted plane, whose
        # in-plane coordinates move as u_i += δa w_i, v_i += δb w_i (w_i = height).
        w = x @ nrm
        _, _, dbp = _plane_local(x, e1, e2, nrm)  # (3, n, 3)
        s_plane = np.column_stack([np.zeros(n), cu[:, 0] * w, cu[:, 1] * w])  # (n, 3)
        a_c = -np.linalg.pinv(jc_flat)  # (3, n)
        dbc = np.einsum("bn,nd->bnd", a_c, g3) + np.einsum("bn,nk,kjd->bjd", a_c, s_plane, dbp)
        dbeta = np.concatenate([dbp, dbc])  # (6, n, 3)
        t = np.zeros((7, 6))
        t[0:3, 0] = nrm
        t[0:3, 1] = c2[0] * nrm
        t[0:3, 2] = c2[1] * nrm
        t[0:3, 3], t[0:3, 4] = e1, e2
        t[3:6, 1], t[3:6, 2] = -e1, -e2
        t[6, 5] = 1.0
        jac = np.einsum("tb,bnd->tnd", t, dbeta)
        local, local_jac = np.column_stack([s_plane, jc_flat]), dbeta
    return _result(
        Circle(centre, r, nrm),
        residuals,
        solve.iterations,
        solve.converged,
        _message("circle", solve, rms),
        jac,
        g3,
        local,
        local_jac,
    )


# ------------------------------------------------------------------- cylinder and cone


def _quadric_axis(x: np.ndarray) -> np.ndarray | None:
    """Axis of the algebraic quadric through centred points x (n ≥ 10), or None.

    The quadric ``xᵀAx + b·x + c = 0`` (smallest right singular vector of the design
    matrix) of a cylinder or cone has a quadratic form A with eigenvalues (1, 1, 0) or
    (1, 1, −tan²ψ) up to scale: the axis is the eigenvector of the distinct eigenvalue.
    """
    if x.shape[0] < 10:  # with 9 points the quadric interpolates: no information
        return None
    y = x / np.sqrt(np.mean(np.sum(x * x, axis=1)))
    u, v, w = y.T
    design = np.column_stack(
        [u * u, v * v, w * w, 2 * u * v, 2 * u * w, 2 * v * w, u, v, w, np.ones(len(u))]
    )
    q = np.linalg.svd(design, full_matrices=False)[2][-1]
    quad = np.array([[q[0], q[3], q[4]], [q[3], q[1], q[5]], [q[4], q[5], q[2]]])
    lam, vecs = np.linalg.eigh(quad)
    return vecs[:, 0] if lam[1] - lam[0] > lam[2] - lam[1] else vecs[:, 2]


def _candidate_axes(x: np.ndarray, direction: object, kind: str) -> list[np.ndarray]:
    """Starting axis directions: the given one, or several rotation-equivariant guesses.

    Without a given direction: the axis of the algebraic quadric through the points;
    the axis from surface normals (local principal components of k nearest neighbours,
    oriented away from the centroid, lie on a circle of the unit sphere whose plane is
    normal to the axis of a cylinder or cone, so the axis is the least-variance direction
    of the centred normals); and the three principal axes of the points (long and short
    cylinders).  Every candidate is refined and the best fit kept.
    """
    if direction is not None:
        a = np.array(direction, dtype=float)
        if a.shape != (3,) or not np.all(np.isfinite(a)) or not np.linalg.norm(a) > 0:
            raise FitError(f"{kind}: direction must be a finite non-zero 3-vector, got {a!r}")
        return [a / np.linalg.norm(a)]
    n = x.shape[0]
    axes = []
    quadric = _quadric_axis(x)
    if quadric is not None:
        axes.append(quadric)
    if n >= 6:
        k = min(n, 8)
        nb = cKDTree(x).query(x, k=k)[1]  # (n, k) neighbour indices
        patches = x[nb] - x[nb].mean(axis=1, keepdims=True)  # (n, k, 3)
        normals = np.linalg.svd(patches)[2][:, 2, :]  # (n, 3)
        outward = np.sum(normals * x, axis=1)
        normals *= np.where(outward < 0, -1.0, 1.0)[:, None]
        cn = normals - normals.mean(axis=0)
        axes.append(np.linalg.svd(cn, full_matrices=False)[2][2])
    axes.extend(np.linalg.svd(x, full_matrices=False)[2])
    return axes


def _cylinder_local(x: np.ndarray, x0: np.ndarray, a: np.ndarray):
    """Residuals and Jacobian of the cylinder distance in Forbes' local frame.

    β = (δx, δy, δa, δb, δr): axis point += δx e1 + δy e2, a += δa e1 + δb e2, r += δr.
    ∂d/∂β = (−x/ρ, −y/ρ, −xz/ρ, −yz/ρ, −1) (Forbes, NPL DITC 140/89, §4.8).
    """
    e1, e2 = _perp_basis(a)
    v = x - x0
    lx, ly, lz = v @ e1, v @ e2, v @ a
    rho = np.hypot(lx, ly)
    j = np.column_stack([-lx / rho, -ly / rho, -lx * lz / rho, -ly * lz / rho, -np.ones(len(x))])
    g = (lx / rho)[:, None] * e1 + (ly / rho)[:, None] * e2  # (n, 3) outward radial
    return rho, j, g, e1, e2


def fit_cylinder(points: object, direction: object = None) -> FitResult:
    """Least-squares cylinder.

    Parameters
    ----------
    points : (n, 3) array, mm
        n ≥ 5 points.
    direction : (3,) array, optional
        Approximate axis direction (e.g. the nominal axis of the bore) used as the
        starting value; the fitted axis is free.  Without it, the axis starts from the
        surface-normal analysis and the principal axes of the points, and the best of
        those fits is kept.

    Returns
    -------
    FitResult
        ``element`` is a :class:`Cylinder` whose point is the foot of the data centroid on
        the axis; ``form_error`` is the least-squares cylindricity (max − min).

    Raises
    ------
    FitError
        Wrong shape, NaN/inf, fewer than 5 points, or points that do not determine a
        cylinder (e.g. coplanar points).

    Notes
    -----
    Minimises ``Σ (ρ_i − r)²``, ``ρ_i = ‖(p_i − x0) × a‖`` (Forbes §4.8; Shakarji §3.6)
    by Gauss–Newton in the local frame of the current axis.
    """
    kind = "cylinder"
    p = _check_points(points, kind, (3,), 5)
    x, centroid, scale = _centred(p)
    _require_spread(kind, x, 3, "coplanar", "; a cylinder needs points off one plane")

    def evaluate(state):
        x0, a, r = state
        rho, j, _, _, _ = _cylinder_local(x, x0, a)
        return rho - r, j

    def retract(state, step):
        x0, a, r = state
        e1, e2 = _perp_basis(a)
        a_new = a + step[2] * e1 + step[3] * e2
        a_new /= np.linalg.norm(a_new)
        x0_new = x0 + step[0] * e1 + step[1] * e2
        x0_new = x0_new - (x0_new @ a_new) * a_new  # foot of the centroid (origin)
        r_new = r + step[4]
        return (x0_new, a_new, r_new) if r_new > 0 else None

    best: _Solve | None = None
    for a in _candidate_axes(x, direction, kind):
        e1, e2 = _perp_basis(a)
        uv = np.column_stack([x @ e1, x @ e2])
        try:
            _require_spread(kind, uv - uv.mean(axis=0), 2, "collinear")
            c2, r0 = _hyper_fit(uv)
        except FitError:
            continue
        solve = _gauss_newton(evaluate, retract, (c2[0] * e1 + c2[1] * e2, a, r0), scale)
        if _better(solve, best):
            best = solve
    if best is None:
        raise FitError(f"{kind}: no starting axis gave a circular cross-section")
    x0, a, r = best.state
    a_canon = _canonical(a)
    rho, j, g, e1, e2 = _cylinder_local(x, x0, a_canon)
    _check_conditioning(kind, j, "axis and radius")
    dbeta = _local_to_points(j[:, None, :], g[:, None, :])  # (5, n, 3)
    t = np.zeros((7, 5))
    t[0:3, 0], t[0:3, 1], t[3:6, 2], t[3:6, 3], t[6, 4] = e1, e2, e1, e2, 1.0
    # Reported point = foot of the centroid c̄: d x0 = dq + a (da·(c̄ − x0)) + a aᵀ dc̄.
    wvec = -x0  # c̄ − x0 in centred coordinates
    t[0:3, 2] += a_canon * (e1 @ wvec)
    t[0:3, 3] += a_canon * (e2 @ wvec)
    direct = np.zeros((7, p.shape[0], 3))
    direct[0:3] = (np.outer(a_canon, a_canon) / p.shape[0])[:, None, :]
    jac = np.einsum("tb,bnd->tnd", t, dbeta) + direct
    residuals = rho - r
    rms = float(np.sqrt(np.mean(residuals**2)))
    return _result(
        Cylinder(x0 + centroid, a_canon, r),
        residuals,
        best.iterations,
        best.converged,
        _message(kind, best, rms),
        jac,
        g,
        j,
        dbeta,
    )


def _cone_local(x: np.ndarray, x0: np.ndarray, a: np.ndarray, psi: float, s: float):
    """Cone distances and Jacobian in the local frame (axis along z through x0).

    d = ρ cos ψ − z sin ψ − s, with s the orthogonal distance from x0 to the surface;
    β = (δx, δy, δa, δb, δψ, δs) (Forbes, NPL DITC 140/89, §4.9).
    """
    e1, e2 = _perp_basis(a)
    v = x - x0
    lx, ly, lz = v @ e1, v @ e2, v @ a
    rho = np.hypot(lx, ly)
    cp, sp = np.cos(psi), np.sin(psi)
    d = rho * cp - lz * sp - s
    j = np.column_stack(
        [
            -cp * lx / rho,
            -cp * ly / rho,
            -cp * lx * lz / rho - sp * lx,
            -cp * ly * lz / rho - sp * ly,
            -rho * sp - lz * cp,
            -np.ones(len(x)),
        ]
    )
    # ∂d/∂p: outward surface normal cos ψ ρ̂ − sin ψ a.
    g = (cp * lx / rho)[:, None] * e1 + (cp * ly / rho)[:, None] * e2 - sp * a
    return d, j, g, e1, e2


def _cone_starts(x: np.ndarray, a: np.ndarray) -> list[tuple]:
    """Starting cones about a candidate axis, as states (x0, a, ψ, s).

    First the algebraic cone ``u² + v² = A u + B v + C + D z + E z²``, i.e.
    ``(u − uc)² + (v − vc)² = (ρ0 + t z)²`` with ``t² = E`` and ``2 ρ0 t = D``, linear in
    (A, B, C, D, E), its axis turned to point into the cone.  When that model has no
    real cone (E ≤ 0: the candidate axis is too far off), two slender cones (ψ = 0.05
    rad) opening either way about the circle through the projected points, from which
    Gauss–Newton can still reach the cone.
    """
    e1, e2 = _perp_basis(a)
    lu, lv, lz = x @ e1, x @ e2, x @ a
    m = np.column_stack([lu, lv, np.ones(len(x)), lz, lz * lz])
    coef = np.linalg.lstsq(m, lu * lu + lv * lv, rcond=None)[0]
    if coef[4] > 0:
        t = float(np.sqrt(coef[4]))
        rho0 = coef[3] / (2.0 * t)
        if np.median(rho0 + t * lz) < 0:
            t, rho0 = -t, -rho0
        axis = a if t > 0 else -a
        psi = float(np.arctan(abs(t)))
        if 0 < psi < np.pi / 2 and rho0 > 0:
            x0 = coef[0] / 2.0 * e1 + coef[1] / 2.0 * e2
            return [(x0, axis, psi, float(rho0 * np.cos(psi)))]
    uv = np.column_stack([lu, lv])
    try:
        _require_spread("cone", uv - uv.mean(axis=0), 2, "collinear")
        c2, rho0 = _hyper_fit(uv)
    except FitError:
        return []
    x0 = c2[0] * e1 + c2[1] * e2
    psi = 0.05
    return [(x0, axis, psi, float(rho0 * np.cos(psi))) for axis in (a, -a)]


def fit_cone(points: object, direction: object = None) -> FitResult:
    """Least-squares cone.

    Parameters
    ----------
    points : (n, 3) array, mm
        n ≥ 6 points.
    direction : (3,) array, optional
        Approximate axis direction (either sense) used as the starting value; the fitted
        axis is free and points into the cone (the radius grows along it).  Give it for
        sparse sets (fewer than 10 points on a partial cone), where the automatic axis
        candidates can lead to a local minimum (compare ``rms`` with the probing noise).

    Returns
    -------
    FitResult
        ``element`` is a :class:`Cone` (apex, direction, half-angle); ``form_error`` is
        the least-squares conicity (max − min).

    Raises
    ------
    FitError
        Wrong shape, NaN/inf, fewer than 6 points, or points that do not determine a cone.

    Notes
    -----
    Minimises ``Σ (ρ_i cos ψ − z_i sin ψ − s)²`` about an axis point x0 (the foot of the
    centroid) at orthogonal distance s from the surface (Forbes §4.9; Shakarji §3.7);
    the apex is ``x0 − (s / sin ψ) a``.  Starting values from a linear cone model about
    candidate axes.
    """
    kind = "cone"
    p = _check_points(points, kind, (3,), 6)
    x, centroid, scale = _centred(p)
    _require_spread(kind, x, 3, "coplanar", "; a cone needs points off one plane")

    def evaluate(state):
        x0, a, psi, s = state
        d, j, _, _, _ = _cone_local(x, x0, a, psi, s)
        return d, j

    def retract(state, step):
        x0, a, psi, s = state
        e1, e2 = _perp_basis(a)
        a_new = a + step[2] * e1 + step[3] * e2
        a_new /= np.linalg.norm(a_new)
        psi_new = psi + step[4]
        if not 0 < psi_new < np.pi / 2:
            return None
        x0_new = x0 + step[0] * e1 + step[1] * e2
        tau = -(x0_new @ a_new)  # slide to the foot of the centroid
        return (x0_new + tau * a_new, a_new, psi_new, s + step[5] + tau * np.sin(psi_new))

    best: _Solve | None = None
    for a in _candidate_axes(x, direction, kind):
        for start in _cone_starts(x, a):
            solve = _gauss_newton(evaluate, retract, start, scale)
            if _better(solve, best):
                best = solve
    if best is None:
        raise FitError(f"{kind}: no starting axis gave a conical surface")
    x0, a, psi, s = best.state
    d, j, g, e1, e2 = _cone_local(x, x0, a, psi, s)
    _check_conditioning(kind, j, "axis, half-angle and size")
    dbeta = _local_to_points(j[:, None, :], g[:, None, :])  # (6, n, 3)
    sp, cp = np.sin(psi), np.cos(psi)
    t = np.zeros((7, 6))
    # apex = q − (s / sin ψ) a
    t[0:3, 0], t[0:3, 1] = e1, e2
    t[0:3, 2], t[0:3, 3] = -(s / sp) * e1, -(s / sp) * e2
    t[0:3, 4] = (s * cp / sp**2) * a
    t[0:3, 5] = -a / sp
    t[3:6, 2], t[3:6, 3], t[6, 4] = e1, e2, 1.0
    jac = np.einsum("tb,bnd->tnd", t, dbeta)
    apex = x0 - (s / sp) * a + centroid
    rms = float(np.sqrt(np.mean(d**2)))
    return _result(
        Cone(apex, a, psi),
        d,
        best.iterations,
        best.converged,
        _message(kind, best, rms),
        jac,
        g,
        j,
        dbeta,
    )
