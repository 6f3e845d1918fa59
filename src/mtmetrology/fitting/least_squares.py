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

References
----------
A. B. Forbes, *Least-squares best-fit geometric elements*, NPL Report DITC 140/89,
National Physical Laboratory, Teddington, 1989 (revised 1991).
C. M. Shakarji, "Least-squares fitting algorithms of the NIST algorithm testing system",
J. Res. Natl. Inst. Stand. Technol. 103 (1998) 633–641.
A. Al-Sharadqah, N. Chernov, "Error analysis for circle fitting algorithms", Electron. J.
Stat. 3 (2009) 886–911.
ISO 10360-6:2001, *Geometrical Product Specifications (GPS) — Acceptance and reverification
tests for coordinate measuring machines (CMM) — Part 6: Estimation of errors in computing
Gaussian associated features*.
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine Tool
Metrology*. PhD thesis, Polytechnique Montréal, Ch. 5 and 6.
Mutilba, U., Gomez-Acedo, E., Sandá, A., Vega, I., Yagüe-Fabra, J. A. (2019). Uncertainty
assessment for on-machine tool measurement: an alternative approach to the ISO 15530-3
technical specification. IK4-Tekniker / Universidad de Zaragoza.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.fitting.axial import fit_cone, fit_cylinder
from mtmetrology.fitting.elements import Circle, Line, Plane, Sphere
from mtmetrology.fitting.geometry import canonical, centred, perpendicular_basis, singular_values
from mtmetrology.fitting.odr import (
    FitResult,
    Sensitivities,
    check_conditioning,
    fit_message,
    fit_result,
    hyper_fit,
    local_to_points,
    solve_distances,
)
from mtmetrology.fitting.validation import DEGENERATE, FitError, check_points, require_spread
from mtmetrology.optimize import LeastSquaresResult

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
    p = check_points(points, "line", (2, 3), 2)
    x, centroid, _ = centred(p)
    n, dim = p.shape
    s, vt = np.linalg.svd(x, full_matrices=False)[1:]
    if s[0] <= DEGENERATE * max(float(np.abs(p).max()), 1.0):
        raise FitError(f"line: the {n} points coincide; a line needs two distinct points")
    a = canonical(vt[0])
    line = Line(centroid, a)
    along = x @ a  # (n,) axial coordinates
    if dim == 2:
        nrm = line.normal
        y = x @ nrm  # (n,) signed distances
        # Local parameters β = (δy, δa): point += δy·nrm, direction += δa·nrm.
        j = np.stack([-np.ones(n), -along], axis=1)[:, None, :]  # (n, 1, 2)
        g = np.broadcast_to(nrm, (n, 1, 2))

        def line_2d() -> Sensitivities:
            dbeta = local_to_points(j, g)  # (2, n, 2)
            t = np.zeros((4, 2))
            t[0:2, 0] = nrm
            t[2:4, 1] = nrm
            direct = np.zeros((4, n, 2))
            direct[0:2] = (np.outer(a, a) / n)[:, None, :]
            jac = np.einsum("tb,bnd->tnd", t, dbeta) + direct
            return Sensitivities(jac, g[:, 0, :], j[:, 0, :], dbeta)

        return fit_result(line, y, None, "line: closed-form SVD fit", line_2d)
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

    def line_3d() -> Sensitivities:
        dbeta = local_to_points(j, g)  # (4, n, 3)
        t = np.zeros((6, 4))
        t[0:3, 0], t[0:3, 1], t[3:6, 2], t[3:6, 3] = e1, e2, e1, e2
        direct = np.zeros((6, n, 3))
        direct[0:3] = (np.outer(a, a) / n)[:, None, :]
        jac = np.einsum("tb,bnd->tnd", t, dbeta) + direct
        # The distance ρ = ‖(u, v)‖ differentiates along the unit offset (u, v)/ρ.
        with np.errstate(invalid="ignore", divide="ignore"):
            w = np.where(rho[:, None] > 0, np.stack([u, v], axis=1) / rho[:, None], 0.0)
        return Sensitivities(
            jac, np.einsum("nq,nqd->nd", w, g), np.einsum("nq,nqp->np", w, j), dbeta
        )

    return fit_result(
        line, rho, None, "line: closed-form SVD fit", line_3d, form_error=float(2.0 * rho.max())
    )


def _plane_core(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """SVD frame (e1, e2, n) of centred points; n canonical, (e1, e2, n) right-handed."""
    vt = np.linalg.svd(x, full_matrices=False)[2]
    nrm = canonical(vt[2])
    e1 = vt[0]
    return e1, np.cross(nrm, e1), nrm


def _plane_local(x: np.ndarray, e1: np.ndarray, e2: np.ndarray, nrm: np.ndarray):
    """Local plane Jacobian: β = (δz, δa, δb), point += δz n, n −= δa e1 + δb e2."""
    n = x.shape[0]
    j = np.stack([-np.ones(n), -(x @ e1), -(x @ e2)], axis=1)[:, None, :]  # (n, 1, 3)
    g = np.broadcast_to(nrm, (n, 1, 3))
    return j, g, local_to_points(j, g)  # dβ/dP (3, n, 3)


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
    points (Forbes, NPL DITC 140/89, §4.3).  The algebraic form ``p·x + 1 = 0`` of Mutilba et
    al. (2019) is singular for planes through the origin; this orthogonal fit has no such
    restriction.
    """
    p = check_points(points, "plane", (3,), 3)
    x, centroid, _ = centred(p)
    n = p.shape[0]
    require_spread("plane", singular_values(x), len(x), 2, "collinear")
    e1, e2, nrm = _plane_core(x)

    def plane() -> Sensitivities:
        j, g, dbeta = _plane_local(x, e1, e2, nrm)
        t = np.zeros((6, 3))
        t[0:3, 0] = nrm
        t[3:6, 1], t[3:6, 2] = -e1, -e2
        direct = np.zeros((6, n, 3))
        direct[0:3] = ((np.eye(3) - np.outer(nrm, nrm)) / n)[:, None, :]
        jac = np.einsum("tb,bnd->tnd", t, dbeta) + direct
        return Sensitivities(jac, g[:, 0, :], j[:, 0, :], dbeta)

    return fit_result(Plane(centroid, nrm), x @ nrm, None, "plane: closed-form SVD fit", plane)


# ---------------------------------------------------------------- circle and sphere


def _fit_round(
    x: np.ndarray, scale: float, radius: float | None, kind: str
) -> tuple[np.ndarray, float, LeastSquaresResult]:
    """Geometric circle/sphere fit of centred points (n, d); radius fixed if given."""
    try:
        c0, r0 = hyper_fit(x)
    except FitError as exc:
        raise FitError(f"{kind}: {exc}") from exc
    d = x.shape[1]
    if radius is not None:
        r0 = radius

    def evaluate(state: tuple[np.ndarray, float]) -> tuple[np.ndarray, np.ndarray]:
        return _round_residuals(x, *state, radius is None)

    def retract(state: tuple[np.ndarray, float], step: np.ndarray):
        c, r = state
        if radius is None:
            return (c + step[:d], r + step[d]) if r + step[d] > 0 else None
        return (c + step, r)

    solve = solve_distances(evaluate, retract, (c0, r0), scale)
    c, r = solve.x
    return c, r, solve


def _round_residuals(
    x: np.ndarray, c: np.ndarray, r: float, free_radius: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Distances ``‖x_i − c‖ − r`` (n,) and their Jacobian ``[−u_i, −1]`` (n, d + 1), or
    ``−u_i`` (n, d) with the radius fixed (``u_i`` the outward unit vectors).

    Written into the two output arrays only: no (n, d) temporaries, so a fit to millions
    of points holds little more than its Jacobian.
    """
    n, d = x.shape
    jac = np.empty((n, d + 1 if free_radius else d))
    v = jac[:, :d]
    np.subtract(c, x, out=v)  # −(x − c)
    distances = np.sqrt(np.einsum("ij,ij->i", v, v))
    v /= distances[:, None]  # −u
    if free_radius:
        jac[:, d] = -1.0
    distances -= r
    return distances, jac


def _round_local(j: np.ndarray, d: int) -> tuple[np.ndarray, np.ndarray]:
    """Jacobian pieces of ‖p − c‖ − r at a solved fit: β = (δc, δr) or δc.

    ``j`` (n, 1, p) is the solver's Jacobian ``[−u, −1]`` or ``−u`` at its final point,
    reused rather than evaluated again.  Returns g (n, 1, d) the outward unit vectors and
    dβ/dP (p, n, d).
    """
    g = -j[:, :, :d]
    return g, local_to_points(j, g)


def fit_sphere(points: object, radius: float | None = None) -> FitResult:
    """Least-squares sphere; with ``radius`` given, the centre only.

    Parameters
    ----------
    points : (n, 3) array, mm
        n ≥ 4 points, not coplanar (with a free radius the radius would be
        undetermined; with a known radius the centre has two mirror images).
    radius : float, mm, optional
        Known radius (e.g. the SAMBA master ball radius plus the effective tip radius,
        Sepahi Boroujeni (2021), Ch. 5: ball centre from 5 points).  The fitted radius is then this
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
    Minimises ``Σ (‖p_i − c‖ − r)²`` (Sepahi Boroujeni (2021), Ch. 6; Forbes §4.6) from the
    algebraic hyper fit.  Coplanar points leave the free radius undetermined and a known-radius
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
    p = check_points(points, kind, (3,), 4)
    r_known = None
    if fixed:
        r_known = float(radius)  # type: ignore[arg-type]
        if not np.isfinite(r_known) or r_known <= 0:
            raise FitError(f"{kind}: radius must be a positive finite number, got {radius!r}")
    x, centroid, scale = centred(p)
    del p  # only the centred copy is needed from here (one (n, 3) array less at the peak)
    hint = (
        "; the mirror-image centres cannot be told apart"
        if fixed
        else "; a sphere needs points off one plane (give the radius only if they are not)"
    )
    require_spread(kind, singular_values(x), len(x), 3, "coplanar", hint)
    c, r, solve = _fit_round(x, scale, r_known, kind)
    n = x.shape[0]
    del x  # the sensitivities need only the solver's Jacobian
    j = solve.jacobian[:, None, :]
    check_conditioning(kind, j[:, 0, :], "centre" if fixed else "centre and radius")
    residuals = solve.residuals  # ‖x_i − c‖ − r at the solution

    def sphere() -> Sensitivities:
        g, dbeta = _round_local(j, 3)
        if fixed:  # the known radius has a zero row
            jac = np.zeros((4, n, 3))
            jac[:3] = dbeta
        else:  # (δc, δr) are the parameters themselves: share the (4, n, 3) array
            jac = dbeta
        return Sensitivities(jac, g[:, 0, :], j[:, 0, :], dbeta)

    rms = float(np.sqrt(np.mean(residuals**2)))
    message = fit_message(kind, solve, rms)
    return fit_result(Sphere(c + centroid, r), residuals, solve, message, sphere)


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
    centre (Mutilba et al. (2019), eq. 4; Forbes §4.5: plane first, then circle in it).
    For the 3-D fit without a given plane, the parameter Jacobian includes the
    dependence on the fitted plane (two-stage chain rule).

    Examples
    --------
    >>> fit = fit_circle([[31.75, 0], [0, 31.75], [-31.75, 0], [0, -31.75]])
    >>> round(2 * fit.element.radius, 12), fit.form_error < 1e-12
    (63.5, True)
    """
    p = check_points(points, "circle", (2, 3), 3)
    x, centroid, scale = centred(p)
    n, dim = p.shape
    if dim == 2:
        require_spread("circle", singular_values(x), len(x), 2, "collinear")
        c, r, solve = _fit_round(x, scale, None, "circle")
        j = solve.jacobian[:, None, :]
        check_conditioning("circle", j[:, 0, :], "centre and radius")

        def circle_2d() -> Sensitivities:
            g, dbeta = _round_local(j, 2)
            return Sensitivities(dbeta, g[:, 0, :], j[:, 0, :], dbeta)

        residuals = solve.residuals
        rms = float(np.sqrt(np.mean(residuals**2)))
        message = fit_message("circle", solve, rms)
        return fit_result(Circle(c + centroid, r), residuals, solve, message, circle_2d)
    if plane is not None:
        if not isinstance(plane, Plane):
            raise FitError(f"circle: plane must be a Plane, got {type(plane).__name__}")
        nrm = plane.normal
        e1, e2 = perpendicular_basis(nrm)
        # Origin: the centroid's foot on the given plane.
        origin = centroid - ((centroid - plane.point) @ nrm) * nrm
        x = p - origin
    else:
        require_spread("circle", singular_values(x), len(x), 2, "collinear")
        e1, e2, nrm = _plane_core(x)
        origin = centroid
    uv = np.column_stack([x @ e1, x @ e2])  # (n, 2) in-plane coordinates
    require_spread(
        "circle",
        singular_values(uv - uv.mean(axis=0)),
        len(uv),
        2,
        "collinear in the circle's plane",
    )
    uv_mean = uv.mean(axis=0)
    c2, r, solve = _fit_round(uv - uv_mean, scale, None, "circle")
    c2 = c2 + uv_mean
    jc = solve.jacobian[:, None, :]  # local β_c = (δuc, δvc, δr)
    check_conditioning("circle", jc[:, 0, :], "centre and radius")
    centre = origin + c2[0] * e1 + c2[1] * e2
    residuals = np.linalg.norm(uv - c2, axis=1) - r
    rms = float(np.sqrt(np.mean(residuals**2)))

    def circle_3d() -> Sensitivities:
        cu = _round_local(jc, 2)[0][:, 0, :]  # (n, 2) in-plane unit radial vectors
        g3 = cu[:, 0:1] * e1 + cu[:, 1:2] * e2  # (n, 3) direct derivative of ρ_i − r
        jc_flat = jc[:, 0, :]
        if plane is not None:
            dbeta = local_to_points(jc, g3[:, None, :])  # (3, n, 3)
            t = np.zeros((7, 3))
            t[0:3, 0], t[0:3, 1], t[6, 2] = e1, e2, 1.0
            jac = np.einsum("tb,bnd->tnd", t, dbeta)
            return Sensitivities(jac, g3, jc_flat, dbeta)
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
        return Sensitivities(jac, g3, np.column_stack([s_plane, jc_flat]), dbeta)

    message = fit_message("circle", solve, rms)
    return fit_result(Circle(centre, r, nrm), residuals, solve, message, circle_3d)
