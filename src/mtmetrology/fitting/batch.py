"""Batched least-squares fits of many point sets at once (Monte Carlo trials).

The point sets are stacked as ``(K, n, dim)``: K sets of n points each.  Every fit is the
same orthogonal-distance least-squares element as in
:mod:`mtmetrology.fitting.least_squares` (they agree to 1e-10 mm), computed for all
sets together: an algebraic start (Kåsa) from stacked normal equations, then Gauss–Newton
on stacked ``(p × p)`` normal equations (a Cholesky solve vectorised over K) with a
per-set Levenberg–Marquardt safeguard and per-set convergence checks, iterating only
the sets that have not converged.  Planes and lines use the stacked SVD.  Cylinders are
in :mod:`mtmetrology.fitting.batch_cylinders`, on the Kåsa start and the batched solve
of this module.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology._backend import compiled_module, from_environment
from mtmetrology.fitting.geometry import canonical_rows, centred_sets
from mtmetrology.fitting.validation import (
    FitError,
    check_point_sets,
    require_spread_scatter,
    require_spread_sets,
)
from mtmetrology.optimize import cholesky_solve, least_squares_batch

__all__ = [
    "BatchLineFit",
    "BatchPlaneFit",
    "BatchRoundFit",
    "fit_circles",
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


def _squared_norms(xt: np.ndarray) -> np.ndarray:
    """Σ_d xt[:, d, :]² for coordinate-major sets (k, d, n) -> (k, n)."""
    out = xt[:, 0] * xt[:, 0]
    for j in range(1, xt.shape[1]):
        out += xt[:, j] * xt[:, j]
    return out


def kasa(xt: np.ndarray, scale: np.ndarray, kernels=None) -> tuple[np.ndarray, np.ndarray]:
    """Stacked Kåsa fit ``‖x‖² = 2 c·x + k`` of centred coordinate-major sets (k, d, n):
    the algebraic circle or sphere the batched fits start from.

    One batched product ``D Dᵀ`` of ``D = [2y, 1, ‖y‖²]`` (y = x / scale) holds both the
    normal matrix and the right-hand side (formed by the compiled ``kernels`` when
    given).

    Parameters
    ----------
    xt : (k, d, n) ndarray, mm
        Centred sets, coordinate-major.
    scale : (k,) ndarray, mm
        Size of each set (rms distance from its centroid).
    kernels : module, optional
        The compiled kernels (:mod:`mtmetrology.fitting._kernels`), else numpy.

    Returns
    -------
    centres : (k, d) ndarray, mm
    radii : (k,) ndarray, mm
        ``r = sqrt(k + ‖c‖²)`` (0 where that is negative).

    References
    ----------
    Kåsa, I. (1976). A circle fitting procedure and its error analysis. *IEEE Trans.
    Instrum. Meas.* IM-25(1), 8-14.
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


def solve_sets(normal_equations, x0: np.ndarray, retract, scale: np.ndarray):
    """The project's batched least-squares core on K sets' parameters x0 (K, p).

    ``normal_equations(x, index)`` and ``retract(x, steps, index)`` are those of
    :func:`mtmetrology.optimize.least_squares_batch`.  Distances are differences of
    coordinates of size ``scale`` (K,), so their rounding unit is ``eps·scale``: the
    step tolerance is ``1e-13·scale`` and below the rounding unit the iteration stops when
    the steps stop contracting.

    Returns
    -------
    mtmetrology.optimize.BatchLeastSquaresResult
    """
    return least_squares_batch(
        normal_equations,
        x0,
        retract=retract,
        xtol=_STEP_TOL * scale,
        max_iter=_MAX_ITER,
        residual_rounding=_EPS * scale,
    )


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
    centres, radii = kasa(xt, scale, kernels)
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
    solve = solve_sets(normal_equations, x0, retract, scale)
    out_radii = np.full(n_sets, float(radius)) if fixed else solve.x[:, d]
    return solve.x[:, :d], out_radii, solve.status, solve.nit


def round_residuals(xt: np.ndarray, c: np.ndarray, r: np.ndarray, kernels=None) -> np.ndarray:
    """Radial residuals ``‖x_i − c‖ − r`` (k, n) of coordinate-major sets xt (k, d, n)
    about centres c (k, d) and radii r (k,), mm (by the compiled ``kernels`` when given)."""
    if kernels is not None:
        out = np.empty(xt.shape[::2])
        kernels.round_residuals(xt, np.ascontiguousarray(c), np.ascontiguousarray(r), out)
        return out
    return np.sqrt(_squared_norms(xt - c[:, :, None])) - r[:, None]


def convergence_summary(kind: str, status: np.ndarray) -> str:
    """One line for a batch: all converged, or how many of the sets did not."""
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
        message=convergence_summary(kind, status),
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
    p = check_point_sets(points, kind, (3,), 4)
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
        require_spread_scatter(kind, scatter, start)
        scale = np.sqrt(np.trace(scatter, axis1=1, axis2=2) / xt.shape[2])
        c, r, status[part], nit[part] = _round_gauss_newton(xt, scale, radius, kernels)
        residuals[part] = round_residuals(xt, c, r, kernels)
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
    p = check_point_sets(points, kind, (2, 3), 3)
    x, centroid, scale = centred_sets(p)
    vt = require_spread_sets(kind, x, 2, "collinear")
    if p.shape[2] == 2:
        xt = np.ascontiguousarray(x.transpose(0, 2, 1))
        kernels = _compiled_kernels(len(p))
        c, r, status, nit = _round_gauss_newton(xt, scale, None, kernels)
        res = round_residuals(xt, c, r, kernels)
        centres, normals = c + centroid, None
    else:
        normals = canonical_rows(vt[:, 2])
        e1 = vt[:, 0]
        e2 = np.cross(normals, e1)
        uv = np.stack([np.einsum("knd,kd->kn", x, e1), np.einsum("knd,kd->kn", x, e2)], axis=1)
        uv_mean = uv.mean(axis=2)  # (K, 2); uv is coordinate-major (K, 2, n)
        kernels = _compiled_kernels(len(p))
        c2, r, status, nit = _round_gauss_newton(uv - uv_mean[:, :, None], scale, None, kernels)
        c2 = c2 + uv_mean
        res = round_residuals(np.ascontiguousarray(uv), c2, r, kernels)
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
    p = check_point_sets(points, kind, (3,), 3)
    x, centroid, _ = centred_sets(p)
    vt = require_spread_sets(kind, x, 2, "collinear")
    normals = canonical_rows(vt[:, 2])
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
    p = check_point_sets(points, kind, (2, 3), 2)
    x, centroid, scale = centred_sets(p)
    if np.any(scale == 0):
        raise FitError(f"{kind}: set {int(np.argmax(scale == 0))} has coincident points")
    vt = np.linalg.svd(x, full_matrices=False)[2]
    directions = canonical_rows(vt[:, 0])
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
