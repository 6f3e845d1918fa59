"""Batched least-squares cylinders of many point sets at once (Monte Carlo trials).

The same element as :func:`mtmetrology.fitting.least_squares.fit_cylinder` for K stacked
sets (K, n, 3): per set, the best-scored starting axis (principal axes, the axis of the
algebraic quadric), the Kåsa circle of the points projected about it, then Gauss–Newton
on stacked 5 × 5 normal equations (:func:`mtmetrology.fitting.batch.solve_sets`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology.fitting.batch import convergence_summary, kasa, round_residuals, solve_sets
from mtmetrology.fitting.geometry import canonical_rows
from mtmetrology.fitting.validation import FitError, check_point_sets, require_spread_scatter

__all__ = ["BatchCylinderFit", "fit_cylinders"]

#: Sets per chunk: a thousand keep the temporaries (k, 6, n) in cache.
_CHUNK = 1024
#: Sparser cylinder sets run Gauss–Newton from every starting axis (their scores are
#: unreliable: a circle fits a few projected points about many axes).
_CYLINDER_ALL_STARTS = 10


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
        centre, radius = kasa(uv, scale)
        with np.errstate(invalid="ignore"):
            rms = np.sqrt(np.mean(round_residuals(uv, centre, radius) ** 2, axis=1))
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

    return local, solve_sets(normal_equations, x0, retract, scale)


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
    p = check_point_sets(points, kind, (3,), 5)
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
        require_spread_scatter(kind, scatter, start)
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
        directions[part] = canonical_rows(np.einsum("kd,kdj->kj", d_local, frames))
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
        message=convergence_summary(kind, status),
    )
