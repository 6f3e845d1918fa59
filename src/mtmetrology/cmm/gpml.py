"""The GP of the source as it was written: GPML's exact inference with a parametric mean.

Model (Salacheep 2016, §5.3 and Appendix 3; GPML v3.4 ``gp``/``infExact``/``covSEiso``/
``likGauss``)::

    y = m(x; β) + f(x) + ε,    f ~ GP(0, k),    ε ~ N(0, σ_n²)
    k(x, x') = σ_f² exp(−‖x − x'‖² / (2ℓ²))                       (covSEiso)
    m(x; β) = 0  (meanZero)   or   m(x; β) = β₁ + β₂ x₁ + β₃ x₁²  (eq. 5.11, x₁ only)

Hyper-parameters in GPML's log form ``[β, log ℓ, log σ_f, log σ_n]`` maximise the marginal
likelihood (type-II ML).  With ``K_y = K + σ_n² I = L Lᵀ`` (Cholesky), ``r = y − Hβ`` and
``α = K_y⁻¹ r`` the negative log marginal likelihood and its gradient are (Rasmussen and
Williams 2006, eqs 2.30, 5.9)::

    NLML = ½ rᵀα + Σ log L_ii + (n/2) log 2π
    ∂NLML/∂θ_j = −½ tr((ααᵀ − K_y⁻¹) ∂K_y/∂θ_j),    ∂NLML/∂β = −Hᵀα
    ∂K/∂log ℓ = K ⊙ D/ℓ²,   ∂K/∂log σ_f = 2K,   ∂K_y/∂log σ_n = 2σ_n² I

with ``D`` the squared distances.  Prediction (eqs 2.25–2.26 with the mean of §2.7)::

    m_* = m(x_*; β) + k_*ᵀ α,    s²_* = σ_f² − ‖L⁻¹ k_*‖² + σ_n²   (GPML's ``s2``: of y)

GPML's ``minimize`` (Rasmussen's conjugate gradients with a cubic line search) is replaced
by ``scipy.optimize.minimize`` (BFGS, analytic gradient): the source's optimum is a local
minimum of the NLML, which both reach to the published digits (digest of Salacheep 2016, T5b).
The source's training data come from GPML's ``gpml_randn`` (a Park–Miller generator with
Schrage's multiplication and a Box–Muller transform), ported bit for bit in
:func:`gpml_randn`; the source passes ``sigma_n = 0.01`` as its *seed*.

References
----------
Salacheep, P. (2016). *Error Compensation and Uncertainty Evaluation of CMMs Based on
Kinematic Error Models and Gaussian Processes*. MPhil thesis, Brunel University London,
§5.3, eq. 5.11, Appendix 3.
Rasmussen, C. E., Williams, C. K. I. (2006). *Gaussian Processes for Machine Learning*.
MIT Press, eqs 2.25–2.26, 2.30, 5.9, §2.7.
Park, S. K., Miller, K. W. (1988). Random number generators: good ones are hard to find.
*Communications of the ACM* 31(10), 1192–1201.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import cho_factor, cho_solve, solve_triangular
from scipy.optimize import minimize

from mtmetrology.cmm.notebook import CMMNotebookRepr
from mtmetrology.errors import InputError

__all__ = [
    "MEANS",
    "ParametricGP",
    "SourceGPDemo",
    "fit_parametric_gp",
    "gpml_randn",
    "negative_log_marginal_likelihood",
    "source_gp_data",
    "source_gp_demo",
]

KIND = "gpml-parametric-gp"
DEMO_KIND = "cmm-source-gp-demo"
VERSION = 1
MEANS = ("zero", "quadratic-x1")

#: Initial hyper-parameters of the source's quadratic-mean run (Appendix 3, stage T3).
SOURCE_T3_MEAN = (-0.179669833204103, 0.778362671986138, -0.863234577981942)
SOURCE_T3_COV = (-2.013712762984104, -4.082864313671445)
SOURCE_T3_LIK = -4.485943839204587


def gpml_randn(seed: float, n: int) -> np.ndarray:
    """GPML's ``gpml_randn(seed, n, 1)``: n standard normal deviates, bit for bit.

    Park–Miller minimal standard generator ``u_{i+1} = a u_i mod m`` (a = 7⁵, m = 2³¹ − 1)
    by Schrage's algorithm, started at ``u_0 = fix(seed · 2³¹)``; uniforms ``u_i / 2³¹``;
    Box–Muller ``x = [w cos 2πu₂; w sin 2πu₂]``, ``w = sqrt(−2 log u₁)`` over the two halves
    of the ``N = 2⌈n/2⌉`` uniforms.

    Parameters
    ----------
    seed : float
        In (0, 1): GPML scales it by 2³¹.
    n : int
        Number of deviates.

    Returns
    -------
    ndarray (n,)

    Examples
    --------
    >>> [round(float(v), 8) for v in gpml_randn(0.01, 9)[:3]]
    [-1.70974862, -1.13294317, -1.35885826]
    """
    a, m = 7**5, 2**31 - 1
    q, r = m // a, m % a  # m = a q + r
    big_n = 2 * ((n + 1) // 2)
    u = np.empty(big_n)
    state = int(np.fix(seed * 2**31))
    for i in range(big_n):  # Schrage: a·u mod m without overflow (integers, exact)
        state = a * (state % q) - r * (state // q)
        if state < 0:
            state += m
        u[i] = state / 2**31
    half = big_n // 2
    w = np.sqrt(-2.0 * np.log(u[:half]))
    x = np.concatenate([w * np.cos(2 * np.pi * u[half:]), w * np.sin(2 * np.pi * u[half:])])
    return x[:n]


def _basis(mean: str, x: np.ndarray) -> np.ndarray:
    """Columns of the parametric mean, ``H`` (n, p): ∂m/∂β."""
    if mean == "zero":
        return np.empty((len(x), 0))
    x1 = x[:, 0]
    return np.column_stack([np.ones_like(x1), x1, x1**2])


def _check_mean(mean: str) -> None:
    if mean not in MEANS:
        raise InputError(f"mean {mean!r}: use one of {', '.join(MEANS)}")


def _sq_dist(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum((a[:, None, :] - b[None, :, :]) ** 2, axis=-1)


def negative_log_marginal_likelihood(hyp, x, y, mean: str = "zero"):
    """NLML and its analytic gradient (see the module notes).

    Parameters
    ----------
    hyp : array_like (p + 3,)
        ``[β (p), log ℓ, log σ_f, log σ_n]`` (GPML's ``hyp.mean, hyp.cov, hyp.lik``).
    x : ndarray (n, d)
    y : ndarray (n,)
    mean : {"zero", "quadratic-x1"}

    Returns
    -------
    nlml : float
    gradient : ndarray (p + 3,)
    """
    hyp = np.asarray(hyp, dtype=float)
    h = _basis(mean, x)
    p = h.shape[1]
    beta, (log_l, log_sf, log_sn) = hyp[:p], hyp[p:]
    ell2, sf2, sn2 = np.exp(2 * log_l), np.exp(2 * log_sf), np.exp(2 * log_sn)
    d2 = _sq_dist(x, x)
    k = sf2 * np.exp(-d2 / (2 * ell2))
    n = len(y)
    try:
        c, low = cho_factor(k + sn2 * np.eye(n), lower=True)
    except np.linalg.LinAlgError:  # a trial step too far: the line search backs off
        return np.inf, np.full(hyp.shape, np.nan)
    resid = y - h @ beta
    alpha = cho_solve((c, low), resid)
    nlml = 0.5 * resid @ alpha + np.sum(np.log(np.diag(c))) + 0.5 * n * np.log(2 * np.pi)
    w = np.outer(alpha, alpha) - cho_solve((c, low), np.eye(n))  # ααᵀ − K_y⁻¹
    grad = np.concatenate(
        [
            -h.T @ alpha,
            [
                -0.5 * np.sum(w * (k * d2 / ell2)),
                -0.5 * np.sum(w * (2 * k)),
                -0.5 * np.trace(w) * 2 * sn2,
            ],
        ]
    )
    return float(nlml), grad


@dataclass(frozen=True)
class ParametricGP:
    """A GP with a parametric mean fitted by type-II ML (see the module notes).

    Attributes
    ----------
    mean : str
        ``zero`` or ``quadratic-x1`` (eq. 5.11).
    hyperparameters : tuple of float
        ``[β, log ℓ, log σ_f, log σ_n]`` at the optimum.
    initial : tuple of float
        Where the optimiser started.
    nlml : float
        Negative log marginal likelihood at the optimum.
    inputs : ndarray (n, d)
    targets : ndarray (n,)
    iterations : int
    message : str
        The optimiser's stopping reason.
    """

    mean: str
    hyperparameters: tuple
    initial: tuple
    nlml: float
    inputs: np.ndarray
    targets: np.ndarray
    iterations: int
    message: str

    @property
    def beta(self) -> np.ndarray:
        """Mean coefficients β."""
        return np.asarray(self.hyperparameters[:-3])

    def predict(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Predictive mean ``m_*`` and GPML's variance ``s²_*`` (of y, σ_n² included).

        Parameters
        ----------
        points : ndarray (m, d)

        Returns
        -------
        mean, variance : ndarray (m,)
        """
        z = np.atleast_2d(np.asarray(points, dtype=float))
        log_l, log_sf, log_sn = self.hyperparameters[-3:]
        ell2, sf2, sn2 = np.exp(2 * log_l), np.exp(2 * log_sf), np.exp(2 * log_sn)
        x = self.inputs
        k = sf2 * np.exp(-_sq_dist(x, x) / (2 * ell2))
        c = np.linalg.cholesky(k + sn2 * np.eye(len(x)))
        resid = self.targets - _basis(self.mean, x) @ self.beta
        alpha = cho_solve((c, True), resid)
        ks = sf2 * np.exp(-_sq_dist(x, z) / (2 * ell2))  # (n, m)
        v = solve_triangular(c, ks, lower=True)
        mean = _basis(self.mean, z) @ self.beta + ks.T @ alpha
        return mean, sf2 - np.sum(v**2, axis=0) + sn2

    def to_dict(self) -> dict:
        """File form (version 1)."""
        return {
            "kind": KIND,
            "version": VERSION,
            "mean": self.mean,
            "hyperparameters": list(self.hyperparameters),
            "initial": list(self.initial),
            "nlml": self.nlml,
            "inputs": self.inputs.tolist(),
            "targets": self.targets.tolist(),
            "iterations": self.iterations,
            "message": self.message,
        }

    @classmethod
    def from_dict(cls, doc: dict) -> ParametricGP:
        """Read :meth:`to_dict`'s form back."""
        if doc.get("kind") != KIND or doc.get("version") != VERSION:
            raise InputError(f"GP: expected kind {KIND!r} version {VERSION}")
        _check_mean(doc["mean"])
        return cls(
            doc["mean"],
            tuple(float(v) for v in doc["hyperparameters"]),
            tuple(float(v) for v in doc["initial"]),
            float(doc["nlml"]),
            np.asarray(doc["inputs"], dtype=float),
            np.asarray(doc["targets"], dtype=float),
            int(doc["iterations"]),
            str(doc["message"]),
        )


def fit_parametric_gp(x, y, mean: str = "zero", initial=None) -> ParametricGP:
    """Maximise the marginal likelihood of an SE-iso GP with a parametric mean.

    Parameters
    ----------
    x : array_like (n, d)
        Inputs.
    y : array_like (n,)
        Targets.
    mean : {"zero", "quadratic-x1"}
        ``m = 0`` or ``m = β₁ + β₂x₁ + β₃x₁²`` (Salacheep 2016, eq. 5.11).
    initial : array_like, optional
        Start ``[β, log ℓ, log σ_f, log σ_n]``; default zeros for β, ``[0, 0, log 0.1]``
        (the source's zero-mean start).

    Returns
    -------
    ParametricGP

    Raises
    ------
    InputError
        Unknown mean, shapes that disagree, non-finite data or start.
    """
    _check_mean(mean)
    x = np.atleast_2d(np.asarray(x, dtype=float))
    y = np.asarray(y, dtype=float).ravel()
    p = _basis(mean, x[:1]).shape[1]
    if initial is None:
        initial = np.concatenate([np.zeros(p), [0.0, 0.0, np.log(0.1)]])
    initial = np.asarray(initial, dtype=float).ravel()
    if len(x) != len(y) or initial.size != p + 3:
        raise InputError(
            f"GP: {len(x)} inputs, {len(y)} targets, {initial.size} hyper-parameters "
            f"(the {mean} mean needs {p + 3})"
        )
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y)) and np.all(np.isfinite(initial))):
        raise InputError("GP: inputs, targets and start must be finite")
    res = minimize(
        negative_log_marginal_likelihood,
        initial,
        args=(x, y, mean),
        jac=True,
        method="BFGS",
        options={"gtol": 1e-9, "maxiter": 500},
    )
    return ParametricGP(
        mean,
        tuple(float(v) for v in res.x),
        tuple(float(v) for v in initial),
        float(res.fun),
        x,
        y,
        int(res.nit),
        str(res.message),
    )


def source_gp_data(seed: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """The source's training set (Appendix 3): 3 × 3 plate at 0.4/0.5/0.6, noisy.

    ``noise = gpml_randn(seed, 9)``, ``adjnoise = 0.02 · noise / max(noise)``; the inputs are
    the ball positions (x fastest) each shifted by ``adjnoise`` in both coordinates, the
    targets are ``adjnoise`` itself (the source's "positioning error", units as printed).

    Returns
    -------
    inputs : ndarray (9, 2)
    targets : ndarray (9,)
    """
    g = np.array([0.4, 0.5, 0.6])
    plate = np.column_stack([np.tile(g, 3), np.repeat(g, 3)])
    noise = gpml_randn(seed, 9)
    adj = noise * 0.1 * 0.2 / noise.max()
    return plate + adj[:, None], adj


def _grid() -> np.ndarray:
    z = np.linspace(0.4, 0.6, 21)
    return np.column_stack([np.tile(z, 21), np.repeat(z, 21)])  # x fastest, as the source


@dataclass(frozen=True)
class SourceGPDemo(CMMNotebookRepr):
    """The source's GP demonstration (Ch. 5) re-run: the two fits and their difference map.

    Attributes
    ----------
    zero_mean, quadratic_mean : ParametricGP
    grid : ndarray (441, 2)
        The 21 × 21 prediction grid over [0.4, 0.6]².
    difference : ndarray (441,)
        ``|m_zero − m_quad|`` on the grid (the source's Fig. 5.6 "errors").
    """

    zero_mean: ParametricGP
    quadratic_mean: ParametricGP
    grid: np.ndarray
    difference: np.ndarray

    @property
    def max_difference(self) -> float:
        """Largest ``|m_zero − m_quad|`` on the grid (the source's "< 0.011")."""
        return float(self.difference.max())

    def to_dict(self) -> dict:
        """File form (version 1)."""
        i = int(np.argmax(self.difference))
        return {
            "kind": DEMO_KIND,
            "version": VERSION,
            "provenance": {"source": "Salacheep 2016, Ch. 5 and Appendix 3", "seed": 0.01},
            "zero_mean": self.zero_mean.to_dict(),
            "quadratic_mean": self.quadratic_mean.to_dict(),
            "grid": self.grid.tolist(),
            "difference": self.difference.tolist(),
            "max_difference": self.max_difference,
            "max_difference_at": self.grid[i].tolist(),
        }

    @classmethod
    def from_dict(cls, doc: dict) -> SourceGPDemo:
        """Read :meth:`to_dict`'s form back."""
        if doc.get("kind") != DEMO_KIND or doc.get("version") != VERSION:
            raise InputError(f"GP demo: expected kind {DEMO_KIND!r} version {VERSION}")
        return cls(
            ParametricGP.from_dict(doc["zero_mean"]),
            ParametricGP.from_dict(doc["quadratic_mean"]),
            np.asarray(doc["grid"], dtype=float),
            np.asarray(doc["difference"], dtype=float),
        )


def source_gp_demo(seed: float = 0.01) -> SourceGPDemo:
    """Re-run the source's GP demonstration (Salacheep 2016, §5.3, Appendix 3).

    Zero mean from ``[0, 0, log 0.1]``; quadratic mean (eq. 5.11) from the source's stage-T3
    values; both predicted on the 21 × 21 grid.

    Returns
    -------
    SourceGPDemo
    """
    x, y = source_gp_data(seed)
    zero = fit_parametric_gp(x, y, "zero")
    quad = fit_parametric_gp(x, y, "quadratic-x1", [*SOURCE_T3_MEAN, *SOURCE_T3_COV, SOURCE_T3_LIK])
    z = _grid()
    diff = np.abs(zero.predict(z)[0] - quad.predict(z)[0])
    return SourceGPDemo(zero, quad, z, diff)
