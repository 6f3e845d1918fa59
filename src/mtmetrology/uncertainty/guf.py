"""GUM uncertainty framework: law of propagation of uncertainty (JCGM 100:2008, JCGM 102:2011).

Model convention (shared with Monte Carlo): ``model(X)`` takes ``X`` of shape
``(..., N)`` and returns ``(..., m)``, or ``(...,)`` for a scalar output,
vectorised over the leading axes.  An implicit model is ``model(Y, X) -> h`` with
``h(Y, X) = 0`` of shape ``(..., m)``.

A model may carry ``jacobian`` (analytic sensitivities) and ``output_names`` /
``output_units`` attributes; compiled model files do.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import stats

from mtmetrology.report.notebook import NotebookRepr
from mtmetrology.uncertainty.regions import (
    normal_ellipsoidal_coverage_factor,
    normal_rectangular_coverage_factor,
)

__all__ = ["BudgetRow", "GUFResult", "guf", "welch_satterthwaite"]


@dataclass(frozen=True)
class BudgetRow:
    """One line of an uncertainty budget for one output.

    ``contribution`` is u_i(y) = |c_i| u(x_i) (JCGM 100, 5.1.3); ``share`` is
    u_i²(y)/u_c²(y) (sums to 1 for uncorrelated inputs); ``share_full`` is
    c_i (U_x c)_i / u_c²(y), which includes the covariance terms and always sums to 1.
    """

    input: str
    unit: str
    estimate: float
    u: float
    sensitivity: float
    contribution: float
    dof: float
    share: float
    share_full: float


@dataclass(frozen=True)
class GUFResult(NotebookRepr):
    """Result of :func:`guf`.

    Attributes
    ----------
    names, units : tuple of str, length m
        Output names and unit labels.
    input_names, input_units : tuple of str, length N
    input_estimate, input_uncertainty, input_dof : (N,) ndarray
    input_covariance : (N, N) ndarray
    estimate : (m,) ndarray
    covariance : (m, m) ndarray
        U_y = C U_x Cᵀ.
    sensitivities : (m, N) ndarray
        C (zero for inputs of zero variance when differentiated numerically).
    standard_uncertainty : (m,) ndarray
    correlation : (m, m) ndarray
    largest_eigenvalue : float
        λ_max of ``correlation`` (JCGM 102 validation quantity).
    dof_effective : (m,) ndarray
        Welch–Satterthwaite ν_eff of each output (inf when all ν_i are).
    coverage_factor : (m,) ndarray
        Per-output k from t_ν_eff (normal when ν_eff = inf) for probability p.
    expanded_uncertainty : (m,) ndarray
    interval : (m, 2) ndarray
        y ± U.
    region_coverage_factor : float
        Hyper-ellipsoid k_p = sqrt(χ²_m(p)).
    rectangular_coverage_factor : float
        Bonferroni hyper-rectangle k_q.
    p : float
    scalar : bool
        The model returned a scalar per trial.
    message : str
    """

    names: tuple[str, ...]
    units: tuple[str, ...]
    input_names: tuple[str, ...]
    input_units: tuple[str, ...]
    input_estimate: np.ndarray
    input_uncertainty: np.ndarray
    input_dof: np.ndarray
    input_covariance: np.ndarray
    estimate: np.ndarray
    covariance: np.ndarray
    sensitivities: np.ndarray
    standard_uncertainty: np.ndarray
    correlation: np.ndarray
    largest_eigenvalue: float
    dof_effective: np.ndarray
    coverage_factor: np.ndarray
    expanded_uncertainty: np.ndarray
    interval: np.ndarray
    region_coverage_factor: float
    rectangular_coverage_factor: float
    p: float
    scalar: bool
    message: str

    def budget(self, output: int | str = 0) -> tuple[BudgetRow, ...]:
        """The uncertainty budget of one output (index or name), one row per input."""
        j = self.names.index(output) if isinstance(output, str) else int(output)
        c = self.sensitivities[j]  # (N,)
        var = self.covariance[j, j]
        contrib = np.abs(c) * self.input_uncertainty
        full = c * (self.input_covariance @ c)
        share = contrib**2 / var if var > 0 else np.zeros_like(c)
        share_full = full / var if var > 0 else np.zeros_like(c)
        return tuple(
            BudgetRow(
                self.input_names[i],
                self.input_units[i],
                float(self.input_estimate[i]),
                float(self.input_uncertainty[i]),
                float(c[i]),
                float(contrib[i]),
                float(self.input_dof[i]),
                float(share[i]),
                float(share_full[i]),
            )
            for i in range(c.size)
        )

    def to_dict(self) -> dict:
        """Outputs as ``[{name, value, unit, u, U, k, p, interval, dof}]`` plus region data."""
        return {
            "method": "guf",
            "outputs": [
                {
                    "name": self.names[j],
                    "value": float(self.estimate[j]),
                    "unit": self.units[j],
                    "u": float(self.standard_uncertainty[j]),
                    "U": float(self.expanded_uncertainty[j]),
                    "k": float(self.coverage_factor[j]),
                    "p": self.p,
                    "interval": [float(v) for v in self.interval[j]],
                    "dof": _json_dof(self.dof_effective[j]),
                }
                for j in range(len(self.names))
            ],
            "covariance": {"names": list(self.names), "matrix": self.covariance.tolist()},
            "largest_eigenvalue": self.largest_eigenvalue,
            "region_coverage_factor": self.region_coverage_factor,
            "rectangular_coverage_factor": self.rectangular_coverage_factor,
            "budget": {
                self.names[j]: [
                    {
                        "input": r.input,
                        "unit": r.unit,
                        "estimate": r.estimate,
                        "u": r.u,
                        "sensitivity": r.sensitivity,
                        "contribution": r.contribution,
                        "dof": _json_dof(r.dof),
                        "share": r.share,
                        "share_full": r.share_full,
                    }
                    for r in self.budget(j)
                ]
                for j in range(len(self.names))
            },
            "message": self.message,
        }


def _json_dof(v: float) -> float | None:
    return None if math.isinf(v) else float(v)


def welch_satterthwaite(contributions, dof) -> float:
    """Effective degrees of freedom ν_eff = u_c⁴ / Σ u_i⁴/ν_i (JCGM 100:2008, G.4.1, G.4.2).

    Parameters
    ----------
    contributions : (N,) array_like
        u_i(y) = |c_i| u(x_i) of uncorrelated inputs.
    dof : (N,) array_like
        ν_i (inf allowed).

    Returns
    -------
    float
        ν_eff (inf when every contributing ν_i is infinite).
    """
    u = np.asarray(contributions, dtype=float)
    nu = np.asarray(dof, dtype=float)
    uc4 = float(np.sum(u**2)) ** 2
    finite = np.isfinite(nu) & (u > 0)
    denom = float(np.sum(u[finite] ** 4 / nu[finite]))
    return math.inf if denom == 0.0 else uc4 / denom


def _as_outputs(y) -> tuple[np.ndarray, bool]:
    y = np.asarray(y, dtype=float)
    if y.ndim == 0:
        return y.reshape(1), True
    if y.ndim != 1:
        raise ValueError(
            f"model(x) for x of shape (N,) must return a scalar or (m,), got {y.shape}"
        )
    return y, False


def _central_differences(f: Callable, x: np.ndarray, step: np.ndarray, m: int) -> np.ndarray:
    """(m, N) derivatives of f at x, central differences with step_j; zero steps skipped.

    All 2·n_active evaluations go to the model in one vectorised call.
    """
    n = x.size
    jac = np.zeros((m, n))
    active = np.flatnonzero(step > 0)
    if active.size == 0:
        return jac
    delta = np.zeros((active.size, n))
    delta[np.arange(active.size), active] = step[active]
    points = np.concatenate([x + delta, x - delta])  # (2 n_a, N)
    values = np.asarray(f(points), dtype=float).reshape(2 * active.size, m)  # (2 n_a, m)
    jac[:, active] = (
        (values[: active.size] - values[active.size :]) / (2.0 * step[active, None])
    ).T
    return jac


def _solve_implicit(h, x, y0, jacobian, tol, max_iter):
    """Newton iteration for h(y, x) = 0.

    Returns y (m,), C_y (m, m), C_x (m, N) or None when no Jacobian was given, and
    the number of iterations.
    """
    y = np.atleast_1d(np.asarray(y0, dtype=float)).copy()
    m = y.size
    if not np.all(np.isfinite(y)):
        raise ValueError("y0 contains NaN or inf")

    def c_y(yy):
        # Step relative to |y| (cube root of machine epsilon balances truncation and rounding).
        step = np.cbrt(np.finfo(float).eps) * np.maximum(np.abs(yy), 1.0)
        return _central_differences(
            lambda yp: h(yp, np.broadcast_to(x, (*yp.shape[:-1], x.size))), yy, step, m
        )

    iterations = 0
    converged = False
    while not converged:
        if iterations == max_iter:
            raise ValueError(
                f"implicit model: Newton did not converge in {max_iter} iterations; "
                "give a better y0"
            )
        hv = np.asarray(h(y, x), dtype=float).reshape(m)
        cy = jacobian(y, x)[0] if jacobian is not None else c_y(y)
        dy = np.linalg.solve(np.asarray(cy, dtype=float).reshape(m, m), hv)
        y = y - dy
        iterations += 1
        converged = bool(np.all(np.abs(dy) <= tol * np.maximum(np.abs(y), 1.0)))
    if jacobian is None:
        return y, c_y(y), None, iterations
    cy, cx = jacobian(y, x)
    cy = np.asarray(cy, dtype=float).reshape(m, m)
    return y, cy, np.asarray(cx, dtype=float).reshape(m, x.size), iterations


def guf(
    model: Callable,
    inputs,
    *,
    jacobian: Callable | None = None,
    p: float = 0.95,
    implicit: bool = False,
    y0=None,
    output_names=None,
    output_units=None,
    truncate_dof: bool = True,
    tol: float = 1e-12,
    max_iter: int = 50,
) -> GUFResult:
    """Propagate input covariance through a model by the law of propagation of uncertainty.

    Parameters
    ----------
    model : callable
        Explicit: ``model(X)`` with X (..., N) -> (..., m) or (...,).
        Implicit (``implicit=True``): ``model(Y, X)`` -> h of shape (..., m).
    inputs : InputSet
        Or any object with ``names``, ``units``, ``estimate`` (N,), ``covariance``
        (N, N), ``dof`` (N,) and ``correlation`` (N, N).
    jacobian : callable, optional
        Explicit: ``jacobian(x) -> (m, N)`` (or (N,) for a scalar output).
        Implicit: ``jacobian(y, x) -> (C_y (m, m), C_x (m, N))``.  Defaults to
        ``model.jacobian`` if present, else central differences.
    p : float
        Coverage probability.
    implicit : bool
        Whether ``model`` is h(Y, X) = 0.
    y0 : array_like, optional
        Starting point of Newton's method (required for implicit models).
    output_names, output_units : sequence of str, optional
        Default to ``model.output_names`` / ``model.output_units`` or y1..ym.
    truncate_dof : bool
        Round ν_eff down to an integer before taking the t quantile, as
        JCGM 100:2008 G.4.1 and H.1.6 do (ν_eff itself is reported unrounded).
    tol, max_iter :
        Newton stopping rule (relative step) and iteration limit.

    Returns
    -------
    GUFResult

    Raises
    ------
    ValueError
        Invalid p, NaN estimates, an input of infinite variance, a model that
        returns NaN, an implicit model without y0 or not converging, or
        finite-dof inputs that are correlated (Welch–Satterthwaite does not apply).

    Notes
    -----
    U_y = C U_x Cᵀ (JCGM 102:2011, 6.2.1.3; JCGM 100:2008, 5.2.2 for m = 1).
    Explicit: C = ∂f/∂x at x.  Implicit: C = −C_y⁻¹ C_x with C_y = ∂h/∂Y, C_x = ∂h/∂X
    (JCGM 102:2011, 6.2.2).  Numerical sensitivities use central differences with
    step u(x_j) (JCGM 100:2008, 5.1.3 note 2; seed 000 Ch. 7); inputs with zero
    variance are skipped (sensitivity 0: they contribute nothing).
    Scalar outputs: ν_eff by Welch–Satterthwaite (G.4.1), k = t_{(1+p)/2, ν_eff}.
    The hyper-ellipsoid factor is k_p = sqrt(χ²_m(p)) (JCGM 102:2011, 6.5.2.3).
    """
    if not 0.0 < p < 1.0:
        raise ValueError(f"p must lie in (0, 1), got {p}")
    x = np.asarray(inputs.estimate, dtype=float)
    ux_cov = np.asarray(inputs.covariance, dtype=float)
    names_in = list(inputs.names)
    if not np.all(np.isfinite(x)):
        bad = [names_in[i] for i in np.flatnonzero(~np.isfinite(x))]
        raise ValueError(f"input estimates must be finite; NaN/inf for {bad}")
    u_x = np.sqrt(np.diag(ux_cov))
    if not np.all(np.isfinite(u_x)):
        bad = [names_in[i] for i in np.flatnonzero(~np.isfinite(u_x))]
        raise ValueError(
            f"inputs {bad} have infinite variance (e.g. Student t with dof <= 2); "
            "the GUF cannot propagate them, use Monte Carlo"
        )
    if jacobian is None:
        jacobian = getattr(model, "jacobian", None) if not implicit else None

    iterations = 0
    if implicit:
        if y0 is None:
            raise ValueError("an implicit model needs a starting point y0")
        y, c_y, c_x, iterations = _solve_implicit(model, x, y0, jacobian, tol, max_iter)
        m = y.size
        scalar = np.ndim(y0) == 0
        if c_x is None:
            c_x = _central_differences(
                lambda xp: model(np.broadcast_to(y, (*xp.shape[:-1], m)), xp), x, u_x, m
            )
        sens = -np.linalg.solve(c_y, c_x)  # (m, N)
    else:
        y, scalar = _as_outputs(model(x))
        m = y.size
        if jacobian is not None:
            sens = np.asarray(jacobian(x), dtype=float).reshape(m, x.size)
        else:
            sens = _central_differences(model, x, u_x, m)
    if not np.all(np.isfinite(y)):
        raise ValueError(f"the model returned a non-finite estimate {y} at the input estimates")
    if not np.all(np.isfinite(sens)):
        raise ValueError("non-finite sensitivity coefficients; check the model near the estimates")

    cov = sens @ ux_cov @ sens.T  # (m, m)
    cov = 0.5 * (cov + cov.T)
    u_y = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    live = u_y > 0
    corr = np.eye(m)
    corr[np.ix_(live, live)] = cov[np.ix_(live, live)] / np.outer(u_y[live], u_y[live])
    lam_max = float(np.linalg.eigvalsh(corr)[-1])

    dof_in = np.asarray(inputs.dof, dtype=float)
    _check_ws_applicable(inputs, dof_in, sens)
    contributions = np.abs(sens) * u_x  # (m, N)
    nu_eff = np.array([welch_satterthwaite(contributions[j], dof_in) for j in range(m)])
    k = np.array([_t_factor(p, nu, truncate_dof) for nu in nu_eff])
    expanded = k * u_y
    interval = np.stack([y - expanded, y + expanded], axis=-1)  # (m, 2)

    out_names = _labels(output_names, getattr(model, "output_names", None), m, "y")
    out_units = _labels(output_units, getattr(model, "output_units", None), m, "")
    how = "analytic Jacobian" if jacobian is not None else "central differences (step u(x_j))"
    message = f"{m} output(s), {x.size} inputs, sensitivities by {how}"
    if implicit:
        message += f"; implicit model solved by Newton in {iterations} iteration(s)"
    return GUFResult(
        names=tuple(out_names),
        units=tuple(out_units),
        input_names=tuple(names_in),
        input_units=tuple(inputs.units),
        input_estimate=x,
        input_uncertainty=u_x,
        input_dof=dof_in,
        input_covariance=ux_cov,
        estimate=y,
        covariance=cov,
        sensitivities=sens,
        standard_uncertainty=u_y,
        correlation=corr,
        largest_eigenvalue=lam_max,
        dof_effective=nu_eff,
        coverage_factor=k,
        expanded_uncertainty=expanded,
        interval=interval,
        region_coverage_factor=normal_ellipsoidal_coverage_factor(m, p),
        rectangular_coverage_factor=normal_rectangular_coverage_factor(m, p),
        p=p,
        scalar=bool(scalar),
        message=message,
    )


def _t_factor(p: float, nu: float, truncate: bool) -> float:
    q = 0.5 * (1.0 + p)
    if math.isinf(nu):
        return float(stats.norm.ppf(q))
    if truncate and nu >= 1.0:
        nu = math.floor(nu)
    return float(stats.t.ppf(q, nu))


def _check_ws_applicable(inputs, dof: np.ndarray, sens: np.ndarray) -> None:
    """Welch–Satterthwaite assumes independent inputs; refuse finite-dof correlated ones."""
    corr = np.asarray(getattr(inputs, "correlation", np.eye(dof.size)), dtype=float)
    off = (corr != 0) & ~np.eye(dof.size, dtype=bool)
    relevant = np.any(sens != 0, axis=0)
    for i in np.flatnonzero(np.isfinite(dof) & relevant):
        partners = np.flatnonzero(off[i] & relevant)
        if partners.size:
            names = list(inputs.names)
            raise ValueError(
                f"input {names[i]!r} has finite dof ({dof[i]:g}) and is correlated with "
                f"{names[partners[0]]!r}; the Welch–Satterthwaite formula (JCGM 100 G.4.1) "
                "needs uncorrelated inputs. Give correlated inputs infinite dof or use Monte Carlo"
            )


def _labels(given, from_model, m: int, stem: str) -> list[str]:
    labels = given if given is not None else from_model
    if labels is None:
        return [stem] if m == 1 and stem else [f"{stem}{j + 1}" if stem else "" for j in range(m)]
    labels = [str(v) for v in labels]
    if len(labels) != m:
        raise ValueError(f"expected {m} output labels, got {len(labels)}")
    return labels
