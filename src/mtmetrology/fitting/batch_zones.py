"""Minimum-zone sphericity, roundness, flatness, cylindricity of K point sets at once.

The per-set solvers of :mod:`mtmetrology.fitting.minimum_zone` solve one set at a time
(sequential LP with HiGHS; the convex hull for flatness). A Monte Carlo evaluation of a
minimum-zone form error needs the same answer for 10⁵ sets, so this module solves all of
them together with a batched *exchange algorithm* started from the least-squares element
(the algebraic circle of Kåsa for roundness, as close for the small form errors measured).

Algorithm
---------
About the current element θ (centre of a sphere or circle, normal of a plane, axis of a
cylinder) the
distances are linearised, ``d_i(θ + δ) ≈ d_i + J_i δ``, and the zone ``l ≤ d_i ≤ h`` becomes
the linear Chebyshev (minimax) approximation problem

    minimise t   subject to   |d_i − b_iᵀ x| ≤ t,   b_i = (−J_i, 1),   x = (δ, r),

with ``r = (l + h)/2`` the mid-zone level and ``t = (h − l)/2`` the half-width. With m = p + 1
unknowns in x, its solution is levelled on a *reference* R of m + 1 = p + 2 points:
``d_i − b_iᵀ x = σ_i t`` (i ∈ R), the signs σ those of the dual vector w
(``Σ_R w_i b_i = 0``, the LP multipliers of the active constraints). Stiefel's exchange
(Stiefel 1959; Watson 1980, §2.4) is the dual simplex method of that LP: while a point j
has ``|d_j − b_jᵀ x| > t`` it enters the reference, with sign s = sign of its residual,
and the point whose multiplier first vanishes along ``w + θ u`` (``u`` the null vector of
the enlarged reference with ``u_j = s``) leaves; the levelled ``t`` increases at every
exchange. Once the reference is optimal the step δ is taken and the distances are
linearised again (Newton's method on the active set, quadratically convergent at a
vertex solution: the p + 2 contact points of a regular minimum zone), keeping the
reference as the warm start. Every step is vectorised over the sets: the (p + 2)²
systems are solved stacked by :func:`numpy.linalg.solve`.

A set is handed to the per-set solver (the *fallback*) when its reference becomes
singular, a Newton step increases the true zone width, it has not converged within
``max_iterations``, or its zone is wider than 2 % of its size (``MAX_RELATIVE_WIDTH``:
so far from round or flat, the local zone nearest the start may not be the solver's;
random sets first differed at 14 %); the per-set solver's trust region and exact hull
handle those sets. The result equals the
per-set solver's to well below 1e-9 mm (tests/fitting/test_batch_zones.py).

References
----------
ISO 12180-1:2011 (cylindricity, MZCY), ISO 12181-1:2011 (roundness, MZCI), ISO 12781-1:2011
(flatness, MZPL), *Geometrical product specifications (GPS)*, Part 1: Vocabulary and
parameters; ISO 1101:2017 (form zones).
Stiefel, E. (1959). Über diskrete und lineare Tschebyscheff-Approximationen.
*Numerische Mathematik* 1, 1–28.
Watson, G. A. (1980). *Approximation Theory and Numerical Methods*. Wiley, Ch. 2.
Anthony, G. T., Anthony, H. M., Bittner, B., et al. (1996). Reference software for
finding Chebyshev best-fit geometric elements. *Precision Engineering* 19, 28–36.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology.errors import ConvergenceError
from mtmetrology.fitting.batch import fit_spheres, kasa
from mtmetrology.fitting.batch_cylinders import fit_cylinders
from mtmetrology.fitting.geometry import centred_sets
from mtmetrology.fitting.validation import check_point_sets, require_spread_sets

__all__ = [
    "BatchZoneFit",
    "minimum_zone_cylindricity",
    "minimum_zone_flatness",
    "minimum_zone_roundness",
    "minimum_zone_sphericity",
]

#: Batched exchange and Newton steps per set before the set goes to the per-set solver.
MAX_ITERATIONS = 60
#: Zones wider than this fraction of the set's size go to the per-set solver: far from
#: flat or round, the zone nearest the start need not be the solver's (the hull's global
#: flatness; random sets first differed at 14 %).
MAX_RELATIVE_WIDTH = 0.02
_CHUNK = 8192


@dataclass(frozen=True, eq=False)
class BatchZoneFit:
    """Minimum zones of K point sets.

    Attributes
    ----------
    form_error : (K,) array, mm
        Zone width: radial separation of the two concentric spheres or circles or of the
        two coaxial cylinders, distance between the two parallel planes.
    bounds : (K, 2) array, mm
        The zone boundaries as :class:`mtmetrology.fitting.minimum_zone.ZoneResult`
        gives them: (inner, outer) radii, or (−t/2, t/2) for planes.
    iterations : (K,) int array
        Batched exchange and Newton steps of each set (the steps done before a fallback).
    fallback : (K,) bool array
        The sets solved by the per-set solver instead.
    message : str
    """

    form_error: np.ndarray
    bounds: np.ndarray
    iterations: np.ndarray
    fallback: np.ndarray
    message: str


# --------------------------------------------------------------------------------------
# models: distances and their Jacobian about the current element, vectorised over sets


class _Centre:
    """Sphere (3-D) or circle (2-D) zones: θ = centre, ``d_i = ‖q_i − c‖``,
    ``∂d_i/∂c = −(q_i − c)/d_i``."""

    @staticmethod
    def evaluate(q, c):
        diff = q - c[:, None, :]
        d = np.sqrt(np.einsum("knd,knd->kn", diff, diff))
        return d, -diff / d[..., None]

    @staticmethod
    def move(q, c, delta):
        return c + delta

    @staticmethod
    def reach(delta, size):
        """Largest displacement of the step, mm."""
        return np.max(np.abs(delta), axis=1)


class _Normal:
    """Plane zones: θ = unit normal n, ``d_i = nᵀ q_i``; the normal is tilted by δ in the
    frame (e1, e2) of the current n, ``n ← (n + δ1 e1 + δ2 e2)/‖·‖``, so
    ``∂d_i/∂δ = (q_iᵀ e1, q_iᵀ e2)``."""

    @staticmethod
    def _frame(n):
        helper = np.eye(3)[np.argmin(np.abs(n), axis=1)]
        e1 = np.cross(n, helper)
        e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
        return e1, np.cross(n, e1)

    @classmethod
    def evaluate(cls, q, n):
        e1, e2 = cls._frame(n)
        d = np.einsum("knd,kd->kn", q, n)
        jac = np.stack([np.einsum("knd,kd->kn", q, e1), np.einsum("knd,kd->kn", q, e2)], 2)
        return d, jac

    @classmethod
    def move(cls, q, n, delta):
        e1, e2 = cls._frame(n)
        m = n + delta[:, :1] * e1 + delta[:, 1:] * e2
        return m / np.linalg.norm(m, axis=1, keepdims=True)

    @staticmethod
    def reach(delta, size):
        """Largest displacement of a point by the tilt, mm."""
        return np.max(np.abs(delta), axis=1) * size


class _Axis:
    """Cylinder zones: θ = (point, unit direction a) of the axis, (k, 6). In the frame
    (e1, e2, a) through the axial mean of the points, the axis shifted by (u, v) and
    tilted by (α, β) gives ``ρ_i ≈ ρ_i − (x_i u + y_i v + z_i (x_i α + y_i β))/ρ_i``
    (Forbes, NPL DITC 140/89, §5), as the per-set solver's model."""

    @staticmethod
    def _local(q, theta):
        point, a = theta[:, :3], theta[:, 3:]
        e1, e2 = _Normal._frame(a)
        w = q - point[:, None, :]
        z = np.einsum("knd,kd->kn", w, a)
        z_mean = z.mean(axis=1)
        x, y = np.einsum("knd,kd->kn", w, e1), np.einsum("knd,kd->kn", w, e2)
        return x, y, z - z_mean[:, None], z_mean, e1, e2

    @classmethod
    def evaluate(cls, q, theta):
        x, y, z, _, _, _ = cls._local(q, theta)
        rho = np.hypot(x, y)
        jac = -np.stack([x, y, x * z, y * z], axis=2) / rho[..., None]
        return rho, jac

    @classmethod
    def move(cls, q, theta, delta):
        _, _, _, z_mean, e1, e2 = cls._local(q, theta)
        a = theta[:, 3:]
        point = theta[:, :3] + z_mean[:, None] * a + delta[:, :1] * e1 + delta[:, 1:2] * e2
        a = a + delta[:, 2:3] * e1 + delta[:, 3:] * e2
        return np.concatenate([point, a / np.linalg.norm(a, axis=1, keepdims=True)], axis=1)

    @staticmethod
    def reach(delta, size):
        """Largest displacement of the axis over the points, mm."""
        return np.maximum(np.abs(delta[:, :2]).max(axis=1), np.abs(delta[:, 2:]).max(axis=1) * size)


# --------------------------------------------------------------------------------------
# the batched exchange


def _inverse(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stacked inverses (k, m, m); singular or non-finite ones flagged (k,) and NaN."""
    try:
        inv = np.linalg.inv(a)
    except np.linalg.LinAlgError:
        singular = np.abs(np.linalg.det(a)) <= 1e-300
        inv = np.linalg.inv(np.where(singular[:, None, None], np.eye(a.shape[1]), a))
        inv[singular] = np.nan
    return inv, ~np.all(np.isfinite(inv), axis=(1, 2))


def _levelled(b_ref: np.ndarray, d_ref: np.ndarray, sigma: np.ndarray):
    """Levelled reference: the dual vector w (Σ_R w_i b_i = 0, Σ|w_i| = 1, oriented so
    that t ≥ 0), its signs σ, and the inverse of ``A = [b_ref | σ]``.

    ``w`` is row m of ``A⁻¹`` (``Aᵀw = e_m``) for any last column not orthogonal to it;
    where its signs differ from the column, A is rebuilt with them.
    """
    m = b_ref.shape[2]
    mat = np.concatenate([b_ref, sigma[..., None]], axis=2)  # (k, m+1, m+1)
    inv, bad = _inverse(mat)
    w = inv[:, m, :]
    sig = np.sign(w) * np.where(np.einsum("ki,ki->k", w, d_ref) < 0.0, -1.0, 1.0)[:, None]
    bad |= np.any(sig == 0.0, axis=1)
    sig[bad] = 1.0
    redo = np.flatnonzero(np.any(sig != sigma, axis=1) & ~bad)
    if redo.size:
        mat[redo, :, m] = sig[redo]
        inv[redo], bad_redo = _inverse(mat[redo])
        bad[redo] |= bad_redo
    w = np.nan_to_num(inv[:, m, :])
    w /= np.maximum(np.abs(w).sum(axis=1, keepdims=True), 1e-300)
    return w, sig, np.nan_to_num(inv), bad


def _exchange(model, q: np.ndarray, theta: np.ndarray, size: np.ndarray, max_iterations: int):
    """Minimum zones of the sets ``q`` (k, n, dim) from the elements ``theta``.

    Returns (d, nit, failed): the distances about the final element (k, n), the steps
    taken and the sets that must go to the per-set solver.
    """
    k, n = q.shape[:2]
    d, jac = model.evaluate(q, theta)
    p = jac.shape[2]
    m = p + 1
    # Start: the p + 2 largest least-squares residuals.
    res0 = d - d.mean(axis=1, keepdims=True)
    ref = np.argpartition(-np.abs(res0), m, axis=1)[:, : m + 1]  # (k, m+1)
    # A generic last column: the first levelling finds the reference's dual signs.
    sigma = np.tile(1.0 + np.sqrt(np.arange(2.0, m + 3.0)), (k, 1))
    width = d.max(axis=1) - d.min(axis=1)
    nit = np.zeros(k, dtype=int)
    failed = np.zeros(k, dtype=bool)
    active = np.arange(k)
    tol = 1e-12 * size
    for _ in range(max_iterations):
        if active.size == 0:
            break
        a = active
        nit[a] += 1
        da, ra = d[a], ref[a]
        b = np.concatenate([-jac[a], np.ones((a.size, n, 1))], axis=2)  # (k, n, m)
        r_a = np.arange(a.size)
        b_ref, d_ref = b[r_a[:, None], ra], da[r_a[:, None], ra]  # (k, m+1, m), (k, m+1)
        w, sig, inv, bad = _levelled(b_ref, d_ref, sigma[a])
        sigma[a] = sig
        sol = np.einsum("kij,kj->ki", inv, d_ref)
        x, t = sol[:, :m], sol[:, m]
        res = da - np.einsum("knm,km->kn", b, x)
        j = np.argmax(np.abs(res), axis=1)
        rj = res[r_a, j]
        optimal = np.abs(rj) <= t + tol[a]

        # Exchange on the sets whose reference is not optimal: j enters with the sign s
        # of its residual; along w + θu (u_R = −v, u_j = s, Aᵀv = (s b_j, 0)) the first
        # multiplier to vanish leaves.
        ex = np.flatnonzero(~optimal & ~bad)
        if ex.size:
            s = np.sign(rj[ex])
            v = np.einsum("ki,kij->kj", s[:, None] * b[ex, j[ex]], inv[ex, :m, :])
            we = w[ex]
            ratio = np.where(v * we > 0.0, we / np.where(v == 0.0, 1.0, v), np.inf)
            leave = np.argmin(ratio, axis=1)
            ok = np.isfinite(ratio[np.arange(ex.size), leave])
            sets = a[ex[ok]]
            ref[sets, leave[ok]] = j[ex[ok]]
            sigma[sets, leave[ok]] = s[ok]
            bad[ex[~ok]] = True

        # Newton step on the sets whose reference is optimal.
        st = np.flatnonzero(optimal & ~bad)
        if st.size:
            sets = a[st]
            delta = x[st, :p]
            theta_new = model.move(q[sets], theta[sets], delta)
            d_new, jac_new = model.evaluate(q[sets], theta_new)
            w_new = d_new.max(axis=1) - d_new.min(axis=1)
            worse = w_new > width[sets] + tol[sets]
            keep = ~worse
            good = sets[keep]
            theta[good], d[good], jac[good], width[good] = (
                theta_new[keep],
                d_new[keep],
                jac_new[keep],
                w_new[keep],
            )
            step = model.reach(delta, size[sets])
            done = np.zeros(k, dtype=bool)
            done[good[step[keep] <= tol[good]]] = True
            failed[sets[worse]] = True
            active = active[~done[active]]
        failed[a[bad]] = True
        active = active[~failed[active]]
    failed[active] = True
    return d, nit, failed


def _run(model, q, theta, size, max_iterations):
    """Chunks of :func:`_exchange` (keeps the stacked arrays in cache)."""
    k = q.shape[0]
    d = np.empty(q.shape[:2])
    nit = np.empty(k, dtype=int)
    failed = np.empty(k, dtype=bool)
    for start in range(0, k, _CHUNK):
        part = slice(start, start + _CHUNK)
        d[part], nit[part], failed[part] = _exchange(
            model, q[part], theta[part].copy(), size[part], max_iterations
        )
    failed |= d.max(axis=1) - d.min(axis=1) > MAX_RELATIVE_WIDTH * size
    return d, nit, failed


def _result(low, high, nit, failed, solve, points, plane: bool, what: str) -> BatchZoneFit:
    """Fill the failed sets from the per-set solver ``solve`` and build the result."""
    for kk in np.flatnonzero(failed):
        zone = solve(points[kk])
        if not zone.success:
            raise ConvergenceError(f"{what}: set {kk}: {zone.message}")
        low[kk], high[kk] = zone.bounds
    width = high - low
    if plane:
        low, high = -0.5 * width, 0.5 * width
    n_fb = int(failed.sum())
    return BatchZoneFit(
        form_error=width,
        bounds=np.stack([low, high], axis=1),
        iterations=nit,
        fallback=failed,
        message=f"{what}: {len(width)} sets, {len(width) - n_fb} by the batched exchange, "
        f"{n_fb} by the per-set solver",
    )


def _size(x: np.ndarray) -> np.ndarray:
    """Radius of each centred set about its centroid, mm (K,)."""
    return np.sqrt(np.max(np.einsum("knd,knd->kn", x, x), axis=1))


def minimum_zone_sphericity(
    points: object, *, max_iterations: int = MAX_ITERATIONS
) -> BatchZoneFit:
    """Minimum-zone sphericity of K point sets (ISO 1101 zone of two concentric spheres).

    Parameters
    ----------
    points : (K, n, 3) array_like, mm
        n ≥ 5 non-coplanar points per set.
    max_iterations : int
        Batched steps per set before it goes to
        :func:`mtmetrology.fitting.minimum_zone.sphericity` (0: every set does).

    Returns
    -------
    BatchZoneFit
        ``form_error`` ``W = min_c (max_i ‖q_i − c‖ − min_i ‖q_i − c‖)``, ``bounds`` the
        (inner, outer) radii.

    Raises
    ------
    ConvergenceError
        A set that the per-set solver did not solve either.
    FitError
        Wrong shape, NaN/inf, too few points, a coplanar set (named by its index).

    Notes
    -----
    The batched exchange of the module notes, from the least-squares centres of
    :func:`mtmetrology.fitting.batch.fit_spheres`; the same local minimax zone as the
    per-set solver.

    Examples
    --------
    >>> u = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
    >>> r = 10 + 0.001 * np.array([1, 1, -1, -1, 1, 1])
    >>> round(float(minimum_zone_sphericity([r[:, None] * u]).form_error[0]), 12)
    0.002
    """
    from mtmetrology.fitting.minimax import sphericity

    p = check_point_sets(points, "sphericity", (3,), 5)
    x, centroid, _ = centred_sets(p)
    start = fit_spheres(p).centres - centroid
    d, nit, failed = _run(_Centre, x, start, _size(x), max_iterations)
    low, high = d.min(axis=1), d.max(axis=1)
    return _result(low, high, nit, failed, sphericity, p, False, "sphericity")


def minimum_zone_roundness(points: object, *, max_iterations: int = MAX_ITERATIONS) -> BatchZoneFit:
    """Minimum-zone roundness of K profiles (ISO 12181-1:2011, MZCI).

    Parameters
    ----------
    points : (K, n, 2) or (K, n, 3) array_like, mm
        n ≥ 4 non-collinear points per set; 3-D profiles are projected on their
        least-squares planes, as :func:`mtmetrology.fitting.minimum_zone.roundness` does
        without a given normal.
    max_iterations : int
        Batched steps per set before it goes to the per-set solver (0: every set does).

    Returns
    -------
    BatchZoneFit
        ``form_error`` ``W = min_c (max_i ρ_i − min_i ρ_i)`` over the in-plane centre c,
        ``bounds`` the (inner, outer) radii.

    Raises
    ------
    ConvergenceError
        A set that the per-set solver did not solve either.
    FitError
        Wrong shape, NaN/inf, too few points, a collinear set (named by its index).

    Examples
    --------
    >>> t = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    >>> r = 10 + 0.002 * (np.arange(12) % 2 - 0.5)
    >>> ring = np.c_[r * np.cos(t), r * np.sin(t)]
    >>> round(float(minimum_zone_roundness([ring]).form_error[0]), 12)
    0.002
    """
    from mtmetrology.fitting.minimax import roundness

    p = check_point_sets(points, "roundness", (2, 3), 4)
    x, _, _ = centred_sets(p)
    vt = require_spread_sets("roundness", x, 2, "collinear")
    # In-plane coordinates: the least-squares plane's principal axes for 3-D profiles.
    uv = np.einsum("knd,kjd->knj", x, vt[:, :2]) if p.shape[2] == 3 else x
    # Start: the algebraic (Kåsa) circle, within O(form²/radius) of the least-squares one.
    uvt = np.ascontiguousarray(uv.transpose(0, 2, 1))
    start, _ = kasa(uvt, np.sqrt(np.einsum("kdn,kdn->k", uvt, uvt) / uv.shape[1]))
    d, nit, failed = _run(_Centre, uv, start, _size(x), max_iterations)
    low, high = d.min(axis=1), d.max(axis=1)
    return _result(low, high, nit, failed, roundness, p, False, "roundness")


def minimum_zone_flatness(points: object, *, max_iterations: int = MAX_ITERATIONS) -> BatchZoneFit:
    """Minimum-zone flatness of K point sets (ISO 12781-1:2011, MZPL).

    Parameters
    ----------
    points : (K, n, 3) array_like, mm
        n ≥ 4 non-collinear points per set.
    max_iterations : int
        Batched steps per set before it goes to
        :func:`mtmetrology.fitting.minimum_zone.flatness` (0: every set does).

    Returns
    -------
    BatchZoneFit
        ``form_error`` the distance between the two closest parallel planes containing
        the points, ``bounds`` (−t/2, t/2).

    Raises
    ------
    ConvergenceError
        A set that the per-set solver did not solve either.
    FitError
        Wrong shape, NaN/inf, too few points, a collinear set (named by its index).

    Notes
    -----
    The exchange from the least-squares normal finds the local minimum of the width over
    the normal; the per-set solver is exact (the convex hull), and the two agree for the
    nearly flat sets of measured surfaces (tested on random sets).

    Examples
    --------
    >>> pts = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, 0.5, 0.003]]
    >>> round(float(minimum_zone_flatness([pts]).form_error[0]), 12)
    0.003
    """
    from mtmetrology.fitting.minimum_zone import flatness

    p = check_point_sets(points, "flatness", (3,), 4)
    x, _, _ = centred_sets(p)
    vt = require_spread_sets("flatness", x, 2, "collinear")
    d, nit, failed = _run(_Normal, x, vt[:, 2].copy(), _size(x), max_iterations)
    low, high = d.min(axis=1), d.max(axis=1)
    return _result(low, high, nit, failed, flatness, p, True, "flatness")


def minimum_zone_cylindricity(
    points: object, *, max_iterations: int = MAX_ITERATIONS
) -> BatchZoneFit:
    """Minimum-zone cylindricity of K point sets (ISO 12180-1:2011, MZCY).

    Parameters
    ----------
    points : (K, n, 3) array_like, mm
        n ≥ 6 points per set, not coplanar.
    max_iterations : int
        Batched steps per set before it goes to
        :func:`mtmetrology.fitting.minimum_zone.cylindricity` (0: every set does).

    Returns
    -------
    BatchZoneFit
        ``form_error`` the radial separation of the two closest coaxial cylinders
        containing the points, ``bounds`` their (inner, outer) radii.

    Raises
    ------
    ConvergenceError
        A set that the per-set solver did not solve either.
    FitError
        Wrong shape, NaN/inf, too few points, a coplanar set (named by its index).

    Notes
    -----
    The batched exchange of the module notes on the axis (p = 4: shift and tilt), from
    the least-squares cylinders of :func:`mtmetrology.fitting.batch.fit_cylinders`.

    Examples
    --------
    >>> t = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    >>> r = 12 + 0.001 * np.cos(4 * t)
    >>> ring = np.c_[r * np.cos(t), r * np.sin(t), np.zeros(8)]
    >>> fit = minimum_zone_cylindricity([np.r_[ring, ring + [0, 0, 15]]])
    >>> round(float(fit.form_error[0]), 9)
    0.002
    """
    from mtmetrology.fitting.minimax import cylindricity

    p = check_point_sets(points, "cylindricity", (3,), 6)
    x, centroid, _ = centred_sets(p)
    start = fit_cylinders(p)
    theta = np.concatenate([start.points - centroid, start.directions], axis=1)
    d, nit, failed = _run(_Axis, x, theta, _size(x), max_iterations)
    low, high = d.min(axis=1), d.max(axis=1)
    return _result(low, high, nit, failed, cylindricity, p, False, "cylindricity")
