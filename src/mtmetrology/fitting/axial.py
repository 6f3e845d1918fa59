"""Orthogonal-distance least-squares cylinders and cones.

Part of :mod:`mtmetrology.fitting.least_squares` (which re-exports :func:`fit_cylinder`
and :func:`fit_cone`); see it for the definitions, references and the parameter Jacobians.
Starting axes come from several rotation-invariant guesses (principal directions, the
axis of an algebraic quadric, a given direction); the best converged fit is kept.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.fitting.elements import Cone, Cylinder
from mtmetrology.fitting.geometry import canonical, centred, perpendicular_basis, singular_values
from mtmetrology.fitting.odr import (
    FitResult,
    Sensitivities,
    better_fit,
    check_conditioning,
    fit_message,
    fit_result,
    hyper_fit,
    local_to_points,
    solve_distances,
)
from mtmetrology.fitting.validation import FitError, check_points, require_spread
from mtmetrology.optimize import LeastSquaresResult

__all__ = ["fit_cone", "fit_cylinder"]


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
        # here, not at the top: scipy.spatial is large and only cylinders and cones use it
        from scipy.spatial import cKDTree

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
    e1, e2 = perpendicular_basis(a)
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
    p = check_points(points, kind, (3,), 5)
    x, centroid, scale = centred(p)
    require_spread(
        kind, singular_values(x), len(x), 3, "coplanar", "; a cylinder needs points off one plane"
    )

    def evaluate(state):
        x0, a, r = state
        rho, j, _, _, _ = _cylinder_local(x, x0, a)
        return rho - r, j

    def retract(state, step):
        x0, a, r = state
        e1, e2 = perpendicular_basis(a)
        a_new = a + step[2] * e1 + step[3] * e2
        a_new /= np.linalg.norm(a_new)
        x0_new = x0 + step[0] * e1 + step[1] * e2
        x0_new = x0_new - (x0_new @ a_new) * a_new  # foot of the centroid (origin)
        r_new = r + step[4]
        return (x0_new, a_new, r_new) if r_new > 0 else None

    best: LeastSquaresResult | None = None
    for a in _candidate_axes(x, direction, kind):
        e1, e2 = perpendicular_basis(a)
        uv = np.column_stack([x @ e1, x @ e2])
        try:
            require_spread(kind, singular_values(uv - uv.mean(axis=0)), len(uv), 2, "collinear")
            c2, r0 = hyper_fit(uv)
        except FitError:
            continue
        solve = solve_distances(evaluate, retract, (c2[0] * e1 + c2[1] * e2, a, r0), scale)
        if better_fit(solve, best):
            best = solve
    if best is None:
        raise FitError(f"{kind}: no starting axis gave a circular cross-section")
    x0, a, r = best.x
    a_canon = canonical(a)
    rho, j, g, e1, e2 = _cylinder_local(x, x0, a_canon)
    check_conditioning(kind, j, "axis and radius")
    n = p.shape[0]

    def cylinder() -> Sensitivities:
        dbeta = local_to_points(j[:, None, :], g[:, None, :])  # (5, n, 3)
        t = np.zeros((7, 5))
        t[0:3, 0], t[0:3, 1], t[3:6, 2], t[3:6, 3], t[6, 4] = e1, e2, e1, e2, 1.0
        # Reported point = foot of the centroid c̄: d x0 = dq + a (da·(c̄ − x0)) + a aᵀ dc̄.
        wvec = -x0  # c̄ − x0 in centred coordinates
        t[0:3, 2] += a_canon * (e1 @ wvec)
        t[0:3, 3] += a_canon * (e2 @ wvec)
        direct = np.zeros((7, n, 3))
        direct[0:3] = (np.outer(a_canon, a_canon) / n)[:, None, :]
        jac = np.einsum("tb,bnd->tnd", t, dbeta) + direct
        return Sensitivities(jac, g, j, dbeta)

    residuals = rho - r
    rms = float(np.sqrt(np.mean(residuals**2)))
    element = Cylinder(x0 + centroid, a_canon, r)
    return fit_result(element, residuals, best, fit_message(kind, best, rms), cylinder)


def _cone_local(x: np.ndarray, x0: np.ndarray, a: np.ndarray, psi: float, s: float):
    """Cone distances and Jacobian in the local frame (axis along z through x0).

    d = ρ cos ψ − z sin ψ − s, with s the orthogonal distance from x0 to the surface;
    β = (δx, δy, δa, δb, δψ, δs) (Forbes, NPL DITC 140/89, §4.9).
    """
    e1, e2 = perpendicular_basis(a)
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
    e1, e2 = perpendicular_basis(a)
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
        require_spread("cone", singular_values(uv - uv.mean(axis=0)), len(uv), 2, "collinear")
        c2, rho0 = hyper_fit(uv)
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
    p = check_points(points, kind, (3,), 6)
    x, centroid, scale = centred(p)
    require_spread(
        kind, singular_values(x), len(x), 3, "coplanar", "; a cone needs points off one plane"
    )

    def evaluate(state):
        x0, a, psi, s = state
        d, j, _, _, _ = _cone_local(x, x0, a, psi, s)
        return d, j

    def retract(state, step):
        x0, a, psi, s = state
        e1, e2 = perpendicular_basis(a)
        a_new = a + step[2] * e1 + step[3] * e2
        a_new /= np.linalg.norm(a_new)
        psi_new = psi + step[4]
        if not 0 < psi_new < np.pi / 2:
            return None
        x0_new = x0 + step[0] * e1 + step[1] * e2
        tau = -(x0_new @ a_new)  # slide to the foot of the centroid
        return (x0_new + tau * a_new, a_new, psi_new, s + step[5] + tau * np.sin(psi_new))

    best: LeastSquaresResult | None = None
    for a in _candidate_axes(x, direction, kind):
        for start in _cone_starts(x, a):
            solve = solve_distances(evaluate, retract, start, scale)
            if better_fit(solve, best):
                best = solve
    if best is None:
        raise FitError(f"{kind}: no starting axis gave a conical surface")
    x0, a, psi, s = best.x
    d, j, g, e1, e2 = _cone_local(x, x0, a, psi, s)
    check_conditioning(kind, j, "axis, half-angle and size")
    sp, cp = np.sin(psi), np.cos(psi)

    def cone() -> Sensitivities:
        dbeta = local_to_points(j[:, None, :], g[:, None, :])  # (6, n, 3)
        t = np.zeros((7, 6))
        # apex = q − (s / sin ψ) a
        t[0:3, 0], t[0:3, 1] = e1, e2
        t[0:3, 2], t[0:3, 3] = -(s / sp) * e1, -(s / sp) * e2
        t[0:3, 4] = (s * cp / sp**2) * a
        t[0:3, 5] = -a / sp
        t[3:6, 2], t[3:6, 3], t[6, 4] = e1, e2, 1.0
        return Sensitivities(np.einsum("tb,bnd->tnd", t, dbeta), g, j, dbeta)

    apex = x0 - (s / sp) * a + centroid
    rms = float(np.sqrt(np.mean(d**2)))
    return fit_result(Cone(apex, a, psi), d, best, fit_message(kind, best, rms), cone)
