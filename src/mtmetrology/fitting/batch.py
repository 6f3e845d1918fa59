"""Batched least-squares fits of many point sets at once (Monte Carlo trials).

The point sets are stacked as ``(K, n, dim)``: K sets of n points each.  Every fit is the
same orthogonal-distance least-squares element as in
:mod:`mtmetrology.fitting.least_squares` (they agree to 1e-10 mm), computed for all
sets together: an algebraic start (Kåsa) from stacked normal equations, then Gauss–Newton
on stacked ``(p × p)`` normal equations (a Cholesky solve vectorised over K) with a
per-set Levenberg–Marquardt safeguard and per-set convergence checks, iterating only
the sets that have not converged.  Planes and lines use the stacked SVD.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology._backend import compiled_module, from_environment
from mtmetrology.fitting.validation import DEGENERATE, FitError
from mtmetrology.optimize import cholesky_solve, least_squares_batch

__all__ = [
    "BatchCylinderFit",
    "BatchLineFit",
    "BatchPlaneFit",
    "BatchRoundFit",
    "fit_circles",
    "fit_cylinders",
    "fit_lines",
    "fit_planes",
    "fit_spheres",
]

#: ``"numba"``: the moment matrices of circle/sphere fits are formed by a compiled kernel
#: (when numba is installed); ``"numpy"``: by stacked matrix products.  Set from the
#: environment variable ``MTMETROLOGY_BACKEND`` at import (:mod:`mtmetrology._backend`);
#: may be changed at run time.
BACKEND = from_environment()


#: Fewer sets than this are fitted on numpy (no import of numba for a handful of fits).
_COMPILED_MIN_SETS = 256


def _compiled_kernels(n_sets: int):
    """The compiled kernels module when the numba backend is selected and installed and
    the batch is large enough, else None."""
    if BACKEND != "numba" or n_sets < _COMPILED_MIN_SETS:
        return None
    return compiled_module("mtmetrology.fitting._kernels")


_STEP_TOL = 1e-13
_EPS = float(np.finfo(float).eps)
_MAX_ITER = 100
#: Sets per chunk: a few thousand keep the numpy path's temporaries in cache; the
#: compiled path has no large temporaries, so larger chunks cut the solver's per-call cost.
_CHUNK = 1024
_COMPILED_CHUNK = 16384
#: Sparser cylinder sets run Gauss–Newton from every starting axis (their scores are
#: unreliable: a circle fits a few projected points about many axes).
_CYLINDER_ALL_STARTS = 10


@dataclass(frozen=True, eq=False)
class BatchRoundFit:
    """Circles or spheres fitted to K point sets.

    Attributes
    ----------
    centres : (K, dim) array, mm
    radii : (K,) array, mm
    normals : (K, 3) array or None
        Plane normals of 3-D circles (largest component positive); None otherwise.
    residuals : (K, n) array, mm
        Signed radial deviations (in the circle's plane for 3-D circles).
    rms, form_error : (K,) arrays, mm
        Root mean square and peak-to-valley (max − min) of the residuals.
    status : (K,) int array
        :class:`mtmetrology.optimize.Status` of each set's solve (> 0: converged).
    nit : (K,) int array
        Gauss–Newton iterations per set.
    message : str
    """

    centres: np.ndarray
    radii: np.ndarray
    normals: np.ndarray | None
    residuals: np.ndarray
    rms: np.ndarray
    form_error: np.ndarray
    status: np.ndarray
    nit: np.ndarray
    message: str

    @property
    def success(self) -> np.ndarray:
        """(K,) bool: the sets whose fit converged."""
        return self.status > 0


@dataclass(frozen=True, eq=False)
class BatchCylinderFit:
    """Cylinders fitted to K point sets.

    Attributes
    ----------
    points : (K, 3) array, mm
        Foot of each set's centroid on its axis (as :func:`fit_cylinder`).
    directions : (K, 3) array
        Unit axis directions, largest component positive.
    radii : (K,) array, mm
    residuals : (K, n) array, mm
        Signed radial deviations ``ρ_i − r``.
    rms, form_error : (K,) arrays, mm
        Root mean square and peak-to-valley (least-squares cylindricity) of the residuals.
    status : (K,) int array
        :class:`mtmetrology.optimize.Status` of each set's solve (> 0: converged).
    nit : (K,) int array
        Gauss–Newton iterations per set.
    message : str
    """

    points: np.ndarray
    directions: np.ndarray
    radii: np.ndarray
    residuals: np.ndarray
    rms: np.ndarray
    form_error: np.ndarray
    status: np.ndarray
    nit: np.ndarray
    message: str

    @property
    def success(self) -> np.ndarray:
        """(K,) bool: the sets whose fit converged."""
        return self.status > 0


@dataclass(frozen=True, eq=False)
class BatchPlaneFit:
    """Planes fitted to K point sets: ``points`` (K, 3) centroids, ``normals`` (K, 3),
    ``residuals`` (K, n), ``rms`` and ``form_error`` (flatness) (K,)."""

    points: np.ndarray
    normals: np.ndarray
    residuals: np.ndarray
    rms: np.ndarray
    form_error: np.ndarray
    message: str


@dataclass(frozen=True, eq=False)
class BatchLineFit:
    """Lines fitted to K point sets: ``points`` (K, dim) centroids, ``directions``
    (K, dim), ``residuals`` (K, n) (signed in 2-D, ≥ 0 in 3-D), ``rms`` and
    ``form_error`` (K,) (max − min in 2-D, 2·max in 3-D, as for :func:`fit_line`)."""

    points: np.ndarray
    directions: np.ndarray
    residuals: np.ndarray
    rms: np.ndarray
    form_error: np.ndarray
    message: str


def _check_sets(points: object, kind: str, dims: tuple[int, ...], min_points: int) -> np.ndarray:
    try:
        arr = np.asarray(points, dtype=float)  # not copied: no fit writes into it
    except (TypeError, ValueError) as exc:
        raise FitError(f"{kind}: points must be a numeric (K, n, d) array ({exc})") from exc
    if arr.ndim != 3 or arr.shape[2] not in dims:
        want = " or ".join(f"(K, n, {d})" for d in dims)
        raise FitError(f"{kind}: points must have shape {want}, got {arr.shape}")
    if arr.shape[0] == 0:
        raise FitError(f"{kind}: no point sets (K = 0)")
    if arr.shape[1] < min_points:
        raise FitError(
            f"{kind}: {arr.shape[1]} points per set are fewer than the {min_points} needed"
        )
    bad = ~np.all(np.isfinite(arr), axis=(1, 2))
    if bad.any():
        raise FitError(
            f"{kind}: {int(bad.sum())} set(s) contain NaN or inf (first: set {int(np.argmax(bad))})"
        )
    return arr


def _centred(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    centroid = points.mean(axis=1)  # (K, d)
    x = points - centroid[:, None, :]  # (K, n, d)
    scale = np.sqrt(np.mean(np.sum(x * x, axis=2), axis=1))  # (K,)
    return x, centroid, scale


def _require_spread_sets(kind: str, x: np.ndarray, rank: int, what: str) -> np.ndarray:
    """Stacked form of :func:`.validation.require_spread`: raise naming the first set whose
    centred points span fewer than ``rank`` dims (same threshold, ``DEGENERATE``).

    Returns the stacked right singular vectors (K, d, d) for reuse.
    """
    _, s, vt = np.linalg.svd(x, full_matrices=False)
    rel = s[:, rank - 1] / np.maximum(s[:, 0], 1e-300)
    bad = (s[:, 0] == 0) | (rel <= DEGENERATE)
    if bad.any():
        k = int(np.argmax(bad))
        raise FitError(
            f"{kind}: {int(bad.sum())} set(s) are {what}; first: set {k} "
            f"(relative singular value {rel[k]:.1e} of its centred points)"
        )
    return vt


def _require_spread_scatter(kind: str, scatter: np.ndarray, first_index: int) -> None:
    """Coplanarity check of centred 3-D sets from their 3×3 scatter matrices (k, 3, 3).

    With eigenvalues λ1 ≤ λ2 ≤ λ3, ``det / m2`` (m2 the sum of the principal 2×2 minors)
    lies in [λ1/3, λ1], so ``det ≤ 1e-14 · m2 · trace`` flags sets whose smallest
    singular value is below ~1e-7 of the largest (exactly coplanar sets sit at the
    rounding level ~1e-16); closed-form and much cheaper than stacked eigenvalues.
    """
    a, b, c = scatter[:, 0, 0], scatter[:, 1, 1], scatter[:, 2, 2]
    d, e, f = scatter[:, 0, 1], scatter[:, 0, 2], scatter[:, 1, 2]
    det = a * (b * c - f * f) - d * (d * c - f * e) + e * (d * f - b * e)
    m2 = a * b - d * d + a * c - e * e + b * c - f * f
    bad = det <= 1e-14 * m2 * (a + b + c)
    if bad.any():
        k = int(np.argmax(bad))
        lam = np.linalg.eigvalsh(scatter[k])
        rel = np.sqrt(max(lam[0], 0.0) / max(lam[2], 1e-300))
        raise FitError(
            f"{kind}: {int(bad.sum())} set(s) are coplanar; first: set {first_index + k} "
            f"(relative singular value {rel:.1e} of its centred points)"
        )


def _canonical(v: np.ndarray) -> np.ndarray:
    """Per-row sign convention (K, d): largest component positive."""
    k = np.argmax(np.abs(v), axis=1)
    sign = np.where(v[np.arange(len(v)), k] > 0, 1.0, -1.0)
    return v * sign[:, None]


def _squared_norms(xt: np.ndarray) -> np.ndarray:
    """Σ_d xt[:, d, :]² for coordinate-major sets (k, d, n) -> (k, n)."""
    out = xt[:, 0] * xt[:, 0]
    for j in range(1, xt.shape[1]):
        out += xt[:, j] * xt[:, j]
    return out


def _kasa(xt: np.ndarray, scale: np.ndarray, kernels=None) -> tuple[np.ndarray, np.ndarray]:
    """Stacked Kåsa fit ``‖x‖² = 2 c·x + k`` of centred coordinate-major sets (k, d, n).

    One batched product ``D Dᵀ`` of ``D = [2y, 1, ‖y‖²]`` (y = x / scale) holds both the
    normal matrix and the right-hand side (formed by the compiled ``kernels`` when
    given).  Returns centres (k, d) and radii (k,).
    """
    k, d, n = xt.shape
    if kernels is not None:
        m = np.empty((k, d + 2, d + 2))
        kernels.kasa_moments(xt, np.ascontiguousarray(scale), m)
    else:
        design = np.empty((k, d + 2, n))
        np.multiply(xt, 2.0 / scale[:, None, None], out=design[:, :d])
        design[:, d] = 1.0
        design[:, d + 1] = 0.25 * _squared_norms(design[:, :d])
        m = np.matmul(design, design.transpose(0, 2, 1))  # (k, d + 2, d + 2)
    sol, _ = cholesky_solve(m[:, : d + 1, : d + 1], m[:, : d + 1, d + 1])
    centres = sol[:, :d]
    radii = np.sqrt(np.maximum(sol[:, d] + np.sum(centres * centres, axis=1), 0.0))
    return centres * scale[:, None], radii * scale


def _round_gauss_newton(
    xt: np.ndarray, scale: np.ndarray, radius: float | None, kernels=None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Batched geometric circle/sphere fit of centred coordinate-major sets xt (K, d, n).

    The project's batched least-squares core iterates; this function supplies the stacked
    normal equations from one product per set (see ``moments``), by the compiled
    ``kernels`` module when given, else by numpy.  Returns centres (K, d), radii (K,),
    status (K,), nit (K,).
    """
    n_sets, d, n_points = xt.shape
    centres, radii = _kasa(xt, scale, kernels)
    fixed = radius is not None
    p = d if fixed else d + 1

    def moments(index: np.ndarray, c: np.ndarray, r: np.ndarray) -> np.ndarray:
        """Stacked moment matrices A Aᵀ of A = [u; 1; ρ − r] (k, d + 2, n) of the sets
        ``index``: they hold the normal equations JᵀJ, Jᵀd of J = [−u, −1] and the cost
        Σd² in one product."""
        if kernels is not None:
            out = np.empty((index.size, d + 2, d + 2))
            kernels.round_moments(xt, index, c, r, out)
            return out
        xs = xt if index.size == n_sets else xt[index]  # a view while every set iterates
        a = np.empty((xs.shape[0], d + 2, xs.shape[2]))
        np.subtract(xs, c[:, :, None], out=a[:, :d])
        rho = np.sqrt(_squared_norms(a[:, :d]))  # (k, n)
        a[:, :d] /= rho[:, None, :]
        a[:, d] = 1.0
        np.subtract(rho, r[:, None], out=a[:, d + 1])
        return np.matmul(a, a.transpose(0, 2, 1))  # (k, d + 2, d + 2)

    def normal_equations(x: np.ndarray, index: np.ndarray):
        r = np.full(index.size, float(radius)) if fixed else np.ascontiguousarray(x[:, d])
        m = moments(index, np.ascontiguousarray(x[:, :d]), r)
        return m[:, :p, :p], -m[:, :p, d + 1], m[:, d + 1, d + 1], n_points

    def retract(x: np.ndarray, steps: np.ndarray, index: np.ndarray):
        new = x + steps
        return new, (None if fixed else new[:, d] > 0)

    x0 = centres if fixed else np.column_stack([centres, radii])
    solve = least_squares_batch(
        normal_equations,
        x0,
        retract=retract,
        xtol=_STEP_TOL * scale,
        max_iter=_MAX_ITER,
        residual_rounding=_EPS * scale,
    )
    out_radii = np.full(n_sets, float(radius)) if fixed else solve.x[:, d]
    return solve.x[:, :d], out_radii, solve.status, solve.nit


def _round_residuals(xt: np.ndarray, c: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Radial residuals (k, n) of coordinate-major sets about centres c, radii r."""
    return np.sqrt(_squared_norms(xt - c[:, :, None])) - r[:, None]


def _summary(kind: str, status: np.ndarray) -> str:
    n_bad = int((status <= 0).sum())
    if n_bad == 0:
        return f"{kind}: all {status.size} fits converged"
    return f"{kind}: {n_bad} of {status.size} fits did not converge (see status)"


def _round_fit(kind, centres, radii, normals, residuals, status, nit) -> BatchRoundFit:
    """Assemble a :class:`BatchRoundFit` with its residual statistics."""
    return BatchRoundFit(
        centres=centres,
        radii=radii,
        normals=normals,
        residuals=residuals,
        rms=np.sqrt(np.mean(residuals * residuals, axis=1)),
        form_error=residuals.max(axis=1) - residuals.min(axis=1),
        status=status,
        nit=nit,
        message=_summary(kind, status),
    )


def fit_spheres(points: object, radius: float | None = None) -> BatchRoundFit:
    """Least-squares spheres of K point sets (centre only when ``radius`` is given).

    Parameters
    ----------
    points : (K, n, 3) array, mm
        n ≥ 4 non-coplanar points per set.
    radius : float, mm, optional
        Known radius (SAMBA ball centres); the returned radii are this value.

    Returns
    -------
    BatchRoundFit

    Raises
    ------
    FitError
        Wrong shape, NaN/inf, too few points, or a coplanar set (named by its index).

    Notes
    -----
    Minimises ``Σ_i (‖p_ki − c_k‖ − r_k)²`` for every set k (digest 000 §3.12), the same
    element as :func:`mtmetrology.fitting.least_squares.fit_sphere`.
    """
    kind = "spheres (known radius)" if radius is not None else "spheres"
    p = _check_sets(points, kind, (3,), 4)
    if radius is not None and not (np.isfinite(radius) and radius > 0):
        raise FitError(f"{kind}: radius must be a positive finite number, got {radius!r}")
    n_sets = p.shape[0]
    centres, radii = np.empty((n_sets, 3)), np.empty(n_sets)
    residuals = np.empty(p.shape[:2])
    status, nit = np.empty(n_sets, dtype=np.int8), np.empty(n_sets, dtype=int)
    kernels = _compiled_kernels(n_sets)
    chunk = _CHUNK if kernels is None else _COMPILED_CHUNK
    for start in range(0, n_sets, chunk):
        part = slice(start, start + chunk)
        xt = np.ascontiguousarray(p[part].transpose(0, 2, 1))  # (k, 3, n) coordinate-major
        centroid = xt.mean(axis=2)
        xt -= centroid[:, :, None]
        scatter = np.matmul(xt, xt.transpose(0, 2, 1))  # (k, 3, 3)
        _require_spread_scatter(kind, scatter, start)
        scale = np.sqrt(np.trace(scatter, axis1=1, axis2=2) / xt.shape[2])
        c, r, status[part], nit[part] = _round_gauss_newton(xt, scale, radius, kernels)
        residuals[part] = _round_residuals(xt, c, r)
        centres[part], radii[part] = c + centroid, r
    return _round_fit(kind, centres, radii, None, residuals, status, nit)


def fit_circles(points: object) -> BatchRoundFit:
    """Least-squares circles of K point sets, 2-D or in their least-squares planes (3-D).

    Parameters
    ----------
    points : (K, n, 2) or (K, n, 3) array, mm
        n ≥ 3 non-collinear points per set.

    Returns
    -------
    BatchRoundFit
        ``normals`` is set for 3-D sets; residuals are in-plane radial deviations.

    Raises
    ------
    FitError
        Wrong shape, NaN/inf, too few points, or a collinear set (named by its index).

    Notes
    -----
    Same element as :func:`mtmetrology.fitting.least_squares.fit_circle` without a
    given plane: the plane by SVD, then ``Σ (ρ_i − r)²`` in it (Forbes §4.5).
    """
    kind = "circles"
    p = _check_sets(points, kind, (2, 3), 3)
    x, centroid, scale = _centred(p)
    vt = _require_spread_sets(kind, x, 2, "collinear")
    if p.shape[2] == 2:
        xt = np.ascontiguousarray(x.transpose(0, 2, 1))
        c, r, status, nit = _round_gauss_newton(xt, scale, None, _compiled_kernels(len(p)))
        res = _round_residuals(xt, c, r)
        centres, normals = c + centroid, None
    else:
        normals = _canonical(vt[:, 2])
        e1 = vt[:, 0]
        e2 = np.cross(normals, e1)
        uv = np.stack([np.einsum("knd,kd->kn", x, e1), np.einsum("knd,kd->kn", x, e2)], axis=1)
        uv_mean = uv.mean(axis=2)  # (K, 2); uv is coordinate-major (K, 2, n)
        kernels = _compiled_kernels(len(p))
        c2, r, status, nit = _round_gauss_newton(uv - uv_mean[:, :, None], scale, None, kernels)
        c2 = c2 + uv_mean
        res = _round_residuals(uv, c2, r)
        centres = centroid + c2[:, 0:1] * e1 + c2[:, 1:2] * e2
    return _round_fit(kind, centres, r, normals, res, status, nit)


def fit_planes(points: object) -> BatchPlaneFit:
    """Least-squares planes of K point sets (stacked SVD of the centred sets).

    Parameters
    ----------
    points : (K, n, 3) array, mm
        n ≥ 3 non-collinear points per set.

    Returns
    -------
    BatchPlaneFit
        ``form_error`` is the least-squares flatness of each set.

    Raises
    ------
    FitError
        Wrong shape, NaN/inf, too few points, or a collinear set.
    """
    kind = "planes"
    p = _check_sets(points, kind, (3,), 3)
    x, centroid, _ = _centred(p)
    vt = _require_spread_sets(kind, x, 2, "collinear")
    normals = _canonical(vt[:, 2])
    res = np.einsum("knd,kd->kn", x, normals)
    return BatchPlaneFit(
        points=centroid,
        normals=normals,
        residuals=res,
        rms=np.sqrt(np.mean(res * res, axis=1)),
        form_error=res.max(axis=1) - res.min(axis=1),
        message=f"{kind}: {p.shape[0]} closed-form SVD fits",
    )


def fit_lines(points: object) -> BatchLineFit:
    """Least-squares lines of K point sets, 2-D or 3-D (stacked SVD).

    Parameters
    ----------
    points : (K, n, 2) or (K, n, 3) array, mm
        n ≥ 2 points per set, not all coincident.

    Returns
    -------
    BatchLineFit

    Raises
    ------
    FitError
        Wrong shape, NaN/inf, too few points, or a set of coincident points.
    """
    kind = "lines"
    p = _check_sets(points, kind, (2, 3), 2)
    x, centroid, scale = _centred(p)
    if np.any(scale == 0):
        raise FitError(f"{kind}: set {int(np.argmax(scale == 0))} has coincident points")
    vt = np.linalg.svd(x, full_matrices=False)[2]
    directions = _canonical(vt[:, 0])
    if p.shape[2] == 2:
        normal = np.stack([-directions[:, 1], directions[:, 0]], axis=1)
        res = np.einsum("knd,kd->kn", x, normal)
        form = res.max(axis=1) - res.min(axis=1)
    else:
        along = np.einsum("knd,kd->kn", x, directions)
        res = np.linalg.norm(x - along[..., None] * directions[:, None, :], axis=2)
        form = 2.0 * res.max(axis=1)
    return BatchLineFit(
        points=centroid,
        directions=directions,
        residuals=res,
        rms=np.sqrt(np.mean(res * res, axis=1)),
        form_error=form,
        message=f"{kind}: {p.shape[0]} closed-form SVD fits",
    )


# ------------------------------------------------------------------------------ cylinders


def _perp_frames(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors e1, e2 (k, 3) completing unit axes a (k, 3) to right-handed frames."""
    helper = np.eye(3)[np.argmin(np.abs(a), axis=1)]
    e1 = np.cross(a, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    return e1, np.cross(a, e1)


def _quadric_axes(xt: np.ndarray, scale: np.ndarray) -> np.ndarray:
    """Axes (k, 3) of the algebraic quadrics through centred sets xt (k, 3, n), n ≥ 10.

    As for :func:`fit_cylinder`: the quadric ``xᵀAx + b·x + c = 0`` of a cylinder has A
    with eigenvalues (1, 1, 0) up to scale, and the axis is the eigenvector of the distinct
    one.  The coefficients are the trace-normalised algebraic fit (stacked 10 × 10 solves).
    """
    u, v, w = np.moveaxis(xt / scale[:, None, None], 1, 0)
    one = np.ones_like(u)
    design = np.stack([u * u, v * v, w * w, 2 * u * v, 2 * u * w, 2 * v * w, u, v, w, one], 1)
    moments = np.matmul(design, design.transpose(0, 2, 1))  # (k, 10, 10)
    # Minimise ‖Dᵀq‖ subject to trace(A) = 1 (never 0 for a cylinder): q ∝ M⁻¹t, with a
    # ridge at the rounding level for exact data, whose M is singular.
    moments += 1e-13 * np.trace(moments, axis1=1, axis2=2)[:, None, None] * np.eye(10)
    trace = np.r_[1.0, 1.0, 1.0, np.zeros(7)]
    q = np.linalg.solve(moments, np.broadcast_to(trace, (len(u), 10))[..., None])[..., 0]
    quad = q[:, [[0, 3, 4], [3, 1, 5], [4, 5, 2]]]  # (k, 3, 3)
    lam, vecs = np.linalg.eigh(quad)
    first = (lam[:, 1] - lam[:, 0]) > (lam[:, 2] - lam[:, 1])
    return np.where(first[:, None], vecs[:, :, 0], vecs[:, :, 2])


def _cylinder_starts(xt: np.ndarray, scale: np.ndarray, candidates: np.ndarray):
    """Starts from each candidate axis (k, c, 3), with their scores.

    About each candidate a0 (frame e1, e2), the algebraic (Kåsa) circle of the points
    projected on its normal plane gives the start (u, v, α = β = 0, r) and a score, the
    rms of that circle's residuals: small only about the cylinder's axis (NaN for a
    collinear projection).  Yields ``(rms (k,), a0, e1, e2 (k, 3), x0 (k, 5))``.
    """
    for c in range(candidates.shape[1]):
        a = candidates[:, c]
        e1, e2 = _perp_frames(a)
        uv = np.stack([np.einsum("kdn,kd->kn", xt, e1), np.einsum("kdn,kd->kn", xt, e2)], 1)
        centre, radius = _kasa(uv, scale)
        with np.errstate(invalid="ignore"):
            rms = np.sqrt(np.mean(_round_residuals(uv, centre, radius) ** 2, axis=1))
        x0 = np.zeros((len(a), 5))
        x0[:, :2], x0[:, 4] = centre, radius
        yield rms, a, e1, e2, x0


def _best_scored(starts: list, first_index: int) -> tuple:
    """The start of the best-scored candidate of each set (a set with none raises)."""
    rms = np.stack([s[0] for s in starts])  # (c, k)
    rms[~np.isfinite(rms)] = np.inf
    if np.any(np.isinf(rms.min(axis=0))):
        bad = first_index + int(np.argmax(np.isinf(rms.min(axis=0))))
        raise FitError(f"cylinders: set {bad}: no starting axis gave a circular cross-section")
    pick, rows = np.argmin(rms, axis=0), np.arange(rms.shape[1])
    return tuple(np.stack(field)[pick, rows] for field in zip(*starts, strict=True))


def _merge_per_set(better: np.ndarray, trial: tuple, best: tuple) -> tuple:
    """Per set (first axis), the arrays of ``trial`` where ``better`` else those of ``best``."""
    return tuple(
        np.where(better.reshape(-1, *([1] * (t.ndim - 1))), t, b)
        for t, b in zip(trial, best, strict=True)
    )


def _solve_cylinders(xt, scale, a0, e1, e2, x0):
    """Gauss–Newton from the starts x0 (k, 5) in the frames (e1, e2, a0) of each set.

    Returns the local points (k, 3, n) and the batched solver's result.
    """
    local = np.stack([np.einsum("kdn,kd->kn", xt, f) for f in (e1, e2, a0)], axis=1)
    n_points = xt.shape[2]

    def normal_equations(x, index):
        rows = _cylinder_distances(local[index], x)
        m = np.matmul(rows, rows.transpose(0, 2, 1))  # (k, 6, 6): JᵀJ, Jᵀd, dᵀd
        return m[:, :5, :5], m[:, :5, 5], m[:, 5, 5], n_points

    def retract(x, steps, index):
        new = x + steps
        return new, new[:, 4] > 0

    solve = least_squares_batch(
        normal_equations,
        x0,
        retract=retract,
        xtol=_STEP_TOL * scale,
        max_iter=_MAX_ITER,
        residual_rounding=_EPS * scale,
    )
    return local, solve


def _cylinder_distances(local: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Rows ``[∂ρ/∂(u, v, α, β, r); ρ − r]`` (k, 6, n) of the cylinder residuals.

    ``local`` (k, 3, n) are the points in each set's fixed frame (e1, e2, a0), ``x`` (k, 5)
    the axis through (u, v, 0) with direction d = (α, β, 1), and the radius.  With
    ``w = p − (u, v, 0)``, ``h = w − (w·d/‖d‖²) d`` the perpendicular from the axis and
    ``ρ = ‖h‖``: ``∂ρ/∂(u, v) = −(h_x, h_y)/ρ`` and
    ``∂ρ/∂(α, β) = −(w·d/‖d‖²)(h_x, h_y)/ρ`` (h ⟂ d removes the other terms).
    """
    u, v, alpha, beta, r = (x[:, i, None] for i in range(5))
    wx, wy, wz = local[:, 0] - u, local[:, 1] - v, local[:, 2]
    s = (wx * alpha + wy * beta + wz) / (1.0 + alpha * alpha + beta * beta)
    out = np.empty((x.shape[0], 6, local.shape[2]))
    hx, hy, hz = wx - s * alpha, wy - s * beta, wz - s
    rho = np.sqrt(hx * hx + hy * hy + hz * hz)
    np.divide(-hx, rho, out=out[:, 0])
    np.divide(-hy, rho, out=out[:, 1])
    np.multiply(s, out[:, 0], out=out[:, 2])
    np.multiply(s, out[:, 1], out=out[:, 3])
    out[:, 4] = -1.0
    np.subtract(rho, r, out=out[:, 5])
    return out


def _check_directions(direction: object, n_sets: int) -> np.ndarray | None:
    if direction is None:
        return None
    a = np.array(direction, dtype=float)
    if a.shape not in ((3,), (n_sets, 3)) or not np.all(np.isfinite(a)):
        raise FitError(
            f"cylinders: direction must be a finite (3,) or ({n_sets}, 3) array, got {a.shape}"
        )
    norm = np.linalg.norm(np.atleast_2d(a), axis=1)
    if np.any(norm == 0):
        raise FitError("cylinders: direction must be non-zero")
    return np.broadcast_to(np.atleast_2d(a) / norm[:, None], (n_sets, 3))


def fit_cylinders(points: object, direction: object = None) -> BatchCylinderFit:
    """Least-squares cylinders of K point sets, by one vectorised Gauss–Newton.

    Parameters
    ----------
    points : (K, n, 3) array, mm
        n ≥ 5 non-coplanar points per set.
    direction : (3,) or (K, 3) array, optional
        Approximate axis direction(s) to start from (e.g. the nominal axis of a bore, or
        the fitted axis of the unperturbed task in a Monte Carlo run).  Without it each
        set starts from the best of its three principal axes and the axis of its
        algebraic quadric (n ≥ 10).  Sets of fewer than 10 points are refined from every
        principal axis and keep the best converged fit; such sparse random sets can have
        several local minima, and :func:`fit_cylinder` (which also tries surface-normal
        axes) may then find another one: give ``direction`` for them.

    Returns
    -------
    BatchCylinderFit

    Raises
    ------
    FitError
        Wrong shape, NaN/inf, too few points, a coplanar set, a set with no usable
        starting axis (each named by its index), or a bad ``direction``.

    Notes
    -----
    The same element as :func:`mtmetrology.fitting.least_squares.fit_cylinder`:
    minimise ``Σ_i (ρ_i − r)²``, ``ρ_i`` the distance of point i from the axis (Forbes,
    NPL DITC 140/89, §4.8).  Each set keeps the frame (e1, e2, a0) of its starting axis
    a0 and is parametrised globally in it: the axis through (u, v, 0) with direction
    (α, β, 1), and r.  The starting axis is chosen per set as the candidate whose
    projected points are best fitted by an algebraic circle, which also gives the start
    (u, v, r).  Gauss–Newton then runs on the stacked 5 × 5 normal equations of all sets
    (:func:`mtmetrology.optimize.least_squares_batch`), each set stopping on its own.
    The frame needs the axis to stay away from 90° of a0, which holds from any start
    Gauss–Newton converges from.

    Examples
    --------
    >>> t = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    >>> ring = np.c_[5 * np.cos(t), 5 * np.sin(t), np.zeros(8)]
    >>> sets = np.stack([np.r_[ring, ring + [0, 0, h]] for h in (10.0, 20.0)])
    >>> fit = fit_cylinders(sets)
    >>> fit.radii.round(12).tolist(), fit.directions[:, 2].round(12).tolist()
    ([5.0, 5.0], [1.0, 1.0])
    """
    kind = "cylinders"
    p = _check_sets(points, kind, (3,), 5)
    n_sets, n_points = p.shape[:2]
    given = _check_directions(direction, n_sets)
    points_out, directions, radii = np.empty((n_sets, 3)), np.empty((n_sets, 3)), np.empty(n_sets)
    residuals = np.empty(p.shape[:2])
    status, nit = np.empty(n_sets, dtype=np.int8), np.empty(n_sets, dtype=int)
    for start in range(0, n_sets, _CHUNK):
        part = slice(start, start + _CHUNK)
        xt = np.ascontiguousarray(p[part].transpose(0, 2, 1))  # (k, 3, n) coordinate-major
        centroid = xt.mean(axis=2)
        xt -= centroid[:, :, None]
        scatter = np.matmul(xt, xt.transpose(0, 2, 1))
        _require_spread_scatter(kind, scatter, start)
        scale = np.sqrt(np.trace(scatter, axis1=1, axis2=2) / n_points)
        if given is not None:
            candidates = given[part, None, :]
        else:
            candidates = np.linalg.eigh(scatter)[1].transpose(0, 2, 1)  # (k, 3, 3) rows
            if n_points >= 10:
                candidates = np.concatenate([_quadric_axes(xt, scale)[:, None], candidates], 1)
        starts = list(_cylinder_starts(xt, scale, candidates))
        if n_points >= _CYLINDER_ALL_STARTS:
            starts = [_best_scored(starts, start)]
        best = None
        for _, a0, e1, e2, x0 in starts:
            local, solve = _solve_cylinders(xt, scale, a0, e1, e2, np.nan_to_num(x0, nan=1.0))
            cost = np.where(solve.status > 0, solve.cost, np.inf)
            trial = (cost, a0, e1, e2, local, solve.x, solve.status, solve.nit)
            best = trial if best is None else _merge_per_set(cost < best[0], trial, best)
        _, a0, e1, e2, local, x, status[part], nit[part] = best
        d_local = np.column_stack([x[:, 2], x[:, 3], np.ones(len(x))])
        d_local /= np.linalg.norm(d_local, axis=1, keepdims=True)
        through = np.column_stack([x[:, 0], x[:, 1], np.zeros(len(x))])
        # foot of the centroid (the local origin) on the axis
        foot = through - np.sum(through * d_local, axis=1, keepdims=True) * d_local
        frames = np.stack([e1, e2, a0], axis=1)  # (k, 3, 3) rows: local -> global
        points_out[part] = np.einsum("kd,kdj->kj", foot, frames) + centroid
        directions[part] = _canonical(np.einsum("kd,kdj->kj", d_local, frames))
        radii[part] = x[:, 4]
        residuals[part] = _cylinder_distances(local, x)[:, 5]
    return BatchCylinderFit(
        points=points_out,
        directions=directions,
        radii=radii,
        residuals=residuals,
        rms=np.sqrt(np.mean(residuals * residuals, axis=1)),
        form_error=residuals.max(axis=1) - residuals.min(axis=1),
        status=status,
        nit=nit,
        message=_summary(kind, status),
    )
