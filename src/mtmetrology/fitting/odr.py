"""Orthogonal-distance regression: what the least-squares fits share.

The result object and its sensitivities, the conditioning check, the call of the
project's least-squares core on a fit's local parameters, the comparison of fits from
several starts and the algebraic starting values used by :mod:`.least_squares` (line,
plane, circle, sphere) and :mod:`.axial` (cylinder, cone).  See
:mod:`mtmetrology.fitting.least_squares` for the definitions and references.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any, NamedTuple

import numpy as np

from mtmetrology.display import NotebookRepr
from mtmetrology.fitting.elements import Element
from mtmetrology.fitting.geometry import singular_values
from mtmetrology.fitting.validation import FitError
from mtmetrology.optimize import LeastSquaresResult, Status, least_squares

__all__ = [
    "FitResult",
    "Sensitivities",
    "better_fit",
    "check_conditioning",
    "fit_message",
    "fit_result",
    "hyper_fit",
    "local_to_points",
    "solve_distances",
]

# Gauss–Newton stops when the step is below this fraction of the data size.
_STEP_TOL = 1e-13
_EPS = float(np.finfo(float).eps)
_MAX_ITER = 200


class Sensitivities(NamedTuple):
    """First-order sensitivities of a fit to its points (see :class:`FitResult`).

    ``jacobian`` (n_params, n, dim) is dθ/dP; residual i depends on its own point through
    ``direct`` (n, dim) and on the local parameters through ``local`` (n, p), whose
    derivatives with respect to the points are ``local_jacobian`` (p, n, dim).
    """

    jacobian: np.ndarray
    direct: np.ndarray
    local: np.ndarray
    local_jacobian: np.ndarray


@dataclass(frozen=True, eq=False)
class FitResult(NotebookRepr):
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
    status : int
        :class:`mtmetrology.optimize.Status` of the solve (``EXACT`` for the closed-form
        SVD fits of lines and planes).
    nit, nfev : int
        Iterations and residual evaluations (0 for closed-form fits).
    message : str
    parameter_jacobian : (n_params, n, dim) array
        dθ/dP of ``element.parameters`` with respect to the point coordinates
        (first-order implicit-function form, see the module notes).  Computed on first
        access and kept: at a million points it is the largest array of a fit (96 MB for
        a sphere), and most callers want only the element and the residuals.
    """

    element: Element
    residuals: np.ndarray = field(repr=False)
    rms: float
    form_error: float
    status: int
    nit: int
    nfev: int
    message: str
    # Computes the Sensitivities from the fit's own arrays (captured at fit time, so
    # later changes to the caller's points do not reach it); called at most once.
    _sensitivities: Callable[[], Sensitivities] = field(repr=False)

    @cached_property
    def _computed(self) -> Sensitivities:
        return self._sensitivities()

    @property
    def parameter_jacobian(self) -> np.ndarray:
        return self._computed.jacobian

    @property
    def success(self) -> bool:
        """Whether the fit converged (or was solved in closed form)."""
        return self.status > 0

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
        s = self._computed
        out = np.einsum("ip,pjd->ijd", s.local, s.local_jacobian)
        idx = np.arange(out.shape[0])
        out[idx, idx, :] += s.direct
        return out


def local_to_points(j: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Sensitivities of the local parameters to the points, ``dβ/dP = −J⁺ ∂d/∂P``
    (first-order implicit-function form at the solution), for residuals grouped per point.

    Parameters
    ----------
    j : (n, q, p) ndarray
        Jacobian of the q residuals of each point with respect to the local parameters β.
    g : (n, q, dim) ndarray
        Derivative of each residual with respect to its own point.

    Returns
    -------
    (p, n, dim) ndarray
        ``dβ/dP``.

    Notes
    -----
    ``J⁺ = R⁺R⁺ᵀJᵀ`` with R the triangular factor of ``J = QR`` (so ``R⁺R⁺ᵀ = (JᵀJ)⁺``):
    the pseudo-inverse of the small R instead of a thin SVD of J, whose (n·q, p) factor
    would double the memory of a fit to millions of points.
    """
    n, q, p = j.shape
    flat = j.reshape(n * q, p)
    tri_pinv = np.linalg.pinv(np.linalg.qr(flat, mode="r"))
    a = (-(tri_pinv @ tri_pinv.T) @ flat.T).reshape(p, n, q)
    return np.einsum("pnq,nqd->pnd", a, g)


def check_conditioning(kind: str, j: np.ndarray, names: str) -> None:
    """Refuse a fit whose Jacobian is rank-deficient at the solution.

    Parameters
    ----------
    kind : str
        What is fitted; leads the message.
    j : (m, p) ndarray
        Jacobian of the distances with respect to the local parameters.
    names : str
        The parameters, for the message.

    Raises
    ------
    FitError
        When ``σ_min(j) ≤ 1e-12 σ_max(j)``: the points do not determine the parameters.
    """
    s = singular_values(j)
    if s[-1] <= 1e-12 * s[0]:
        raise FitError(
            f"{kind}: the parameters ({names}) are not determined by these points "
            f"(Jacobian condition number {s[0] / max(s[-1], 1e-300):.1e})"
        )


def solve_distances(
    evaluate: Callable[[Any], tuple[np.ndarray, np.ndarray]],
    retract: Callable[[Any, np.ndarray], Any],
    state: Any,
    scale: float,
) -> LeastSquaresResult:
    """The project's least-squares core (:func:`mtmetrology.optimize.least_squares`) on a
    fit's local parameters: minimise ``Σ d_i²`` over the orthogonal distances d.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(state) -> (d (m,), J (m, p))``: distances, mm, and their Jacobian with
        respect to the local parameters.
    retract : callable
        ``retract(state, δ)`` applies a step δ (p,) in the local parameters and returns the
        new state (None if it leaves the domain).
    state : object
        The starting element.
    scale : float
        Size of the point set, mm.  Distances are differences of coordinates of this size,
        so their rounding unit is ``eps·scale``: below it the cost cannot judge steps and
        the iteration stops when they stop contracting (status 2); the step tolerance is
        ``1e-13·scale``.

    Returns
    -------
    mtmetrology.optimize.LeastSquaresResult
    """
    return least_squares(
        evaluate,
        state,
        retract=retract,
        xtol=_STEP_TOL * scale,
        max_iter=_MAX_ITER,
        residual_rounding=_EPS * scale,
    )


def better_fit(solve: LeastSquaresResult, best: LeastSquaresResult | None) -> bool:
    """Whether a fit from another starting value beats the best so far: converged first,
    then a cost lower beyond rounding (ties keep the earlier, preferred candidate)."""
    if best is None or (solve.success and not best.success):
        return True
    return solve.success == best.success and solve.cost < best.cost * (1.0 - 1e-9)


def fit_message(kind: str, solve: LeastSquaresResult | None, rms: float) -> str:
    """One line from the status: what stopped the fit, and the rms residual."""
    if solve is None:
        return f"{kind}: closed-form SVD fit (rms {rms:.3g} mm)"
    text = f"{kind}: {solve.message} after {solve.nit} iterations (rms {rms:.3g} mm)"
    return text if solve.success else f"{text}; the result is the best point reached"


def fit_result(
    element: Element,
    residuals: np.ndarray,
    solve: LeastSquaresResult | None,
    message: str,
    sensitivities: Callable[[], Sensitivities],
    form_error: float | None = None,
) -> FitResult:
    """Assemble a :class:`FitResult`: rms, peak-to-valley (unless ``form_error`` is given)
    and the solver's status, iterations and evaluations (``EXACT`` and 0 for a closed-form
    fit, ``solve is None``)."""
    rms = float(np.sqrt(np.mean(residuals**2)))
    pv = float(residuals.max() - residuals.min()) if form_error is None else form_error
    return FitResult(
        element=element,
        residuals=residuals,
        rms=rms,
        form_error=pv,
        status=int(Status.EXACT) if solve is None else solve.status,
        nit=0 if solve is None else solve.nit,
        nfev=0 if solve is None else solve.nfev,
        message=message,
        _sensitivities=sensitivities,
    )


def hyper_fit(x: np.ndarray) -> tuple[np.ndarray, float]:
    """Algebraic "hyper" circle/sphere fit of centred points x (n, d).

    Minimises ``AᵀMA`` subject to ``AᵀNA = 1`` for ``A0‖x‖² + b·x + c = 0`` with the
    hyper constraint ``N = 2 N_Taubin − N_Pratt`` (Al-Sharadqah & Chernov, Electron. J.
    Stat. 3 (2009) 886), which has no essential bias; used only as a starting value.

    Parameters
    ----------
    x : (n, d) ndarray, mm
        Centred points, d = 2 (circle) or 3 (sphere).

    Returns
    -------
    centre : (d,) ndarray, mm
        In the centred coordinates.
    radius : float, mm

    Raises
    ------
    FitError
        When no admissible algebraic solution exists, or the points lie on a line or plane.
    """
    import scipy.linalg  # here, not at the top: importing it takes 0.5 s

    n, d = x.shape
    scale = float(np.sqrt(np.einsum("ij,ij->", x, x) / n))
    zmat = np.empty((n, d + 2))  # columns ‖y‖², y, 1 for y = x / scale
    y = zmat[:, 1 : d + 1]
    np.divide(x, scale, out=y)
    z = zmat[:, 0]
    np.einsum("ij,ij->i", y, y, out=z)
    zmat[:, d + 1] = 1.0
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
