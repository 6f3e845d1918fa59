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
from typing import ClassVar

import numpy as np

from mtmetrology.errors import ConvergenceError, InputError
from mtmetrology.optimize import solve_equations
from mtmetrology.uncertainty.outputs import json_dof, output_labels
from mtmetrology.uncertainty.regions import (
    normal_ellipsoidal_coverage_factor,
    normal_rectangular_coverage_factor,
)
from mtmetrology.uncertainty.result import UncertaintyResult
from mtmetrology.units import display_unit

__all__ = ["BudgetRow", "GUFResult", "guf", "variance_shares", "welch_satterthwaite"]


def variance_shares(sensitivities, covariance, groups=None) -> np.ndarray:
    r"""Share of u_c²(y) of each input (or group of inputs), summing to 1.

    .. math::

        s_i = c_i \sum_j c_j\, u(x_i, x_j) / u_c^2(y), \qquad
        u_c^2(y) = \sum_i \sum_j c_i c_j\, u(x_i, x_j) = c^T U_x c

    (JCGM 100:2008, 5.2.2, eq. 16, each double-sum term split half to each of its two
    inputs). Uncorrelated inputs give u_i²(y)/u_c²(y) (JCGM 100, 5.1.3); with
    correlated inputs the shares still sum to 1 exactly, and an input whose covariance
    terms cancel part of u_c²(y) has a negative share. A group's share is the sum of its
    members' (its covariances with other groups are split half and half).

    Parameters
    ----------
    sensitivities : (N,) or (m, N) array_like
        c (one row per output).
    covariance : (N, N) array_like
        U_x.
    groups : mapping of str to index array or slice, optional
        Inputs reported jointly; the result is then a dict of share arrays.

    Returns
    -------
    ndarray, shape like ``sensitivities`` (or dict of (m,) / scalar per group)
        Zero for an output with u_c(y) = 0.

    References
    ----------
    JCGM 100:2008. *Evaluation of measurement data — Guide to the expression of
    uncertainty in measurement*, 5.1.3 and 5.2.2.

    Examples
    --------
    >>> s = variance_shares([1.0, 1.0], [[1.0, -0.5], [-0.5, 4.0]])
    >>> s.round(3).tolist(), float(s.sum())
    ([0.125, 0.875], 1.0)
    """
    c = np.asarray(sensitivities, dtype=float)
    cov = np.asarray(covariance, dtype=float)
    full = c * (c @ cov)  # c_i (U_x c)_i, U_x symmetric
    var = full.sum(axis=-1, keepdims=True)
    share = np.divide(full, var, out=np.zeros_like(full), where=var > 0)
    if groups is None:
        return share
    return {name: share[..., idx].sum(axis=-1) for name, idx in groups.items()}


@dataclass(frozen=True)
class BudgetRow:
    """One line of an uncertainty budget for one output.

    ``contribution`` is u_i(y) = |c_i| u(x_i) (JCGM 100, 5.1.3); ``share`` is the
    variance contribution of :func:`variance_shares`, c_i Σ_j c_j u(x_i, x_j) / u_c²(y):
    it sums to 1 with correlated inputs too, and is negative for an input whose
    covariances cancel part of u_c²(y). ``unit`` is the unit of ``estimate`` and ``u``.
    """

    input: str
    unit: str
    estimate: float
    u: float
    sensitivity: float
    contribution: float
    dof: float
    share: float


@dataclass(frozen=True)
class GUFResult(UncertaintyResult):
    """Result of :func:`guf`: the fields of :class:`.UncertaintyResult` (estimate
    y = f(x), covariance U_y = C U_x Cᵀ, intervals y ± U with U = k u(y), k from
    t_ν_eff, k_p = sqrt(χ²_m(p)) and the Bonferroni k_q) and the GUF's own.

    Attributes
    ----------
    input_names, input_units : tuple of str, length N
    input_estimate, input_standard_uncertainty, input_dof : (N,) ndarray
    input_covariance : (N, N) ndarray
    input_ensemble : (N,) ndarray of int
        Ensemble number of each input (−1: none), see :class:`.InputSet`.
    sensitivities : (m, N) ndarray
        C (zero for inputs of zero variance when differentiated numerically).
    dof_effective : (m,) ndarray
        ν_eff of each output by Welch–Satterthwaite, ensembles counted as one component
        (inf when every contributing ν_i is).
    scalar_model : bool
        The model returned a scalar per evaluation.
    sensitivity_method : {"analytic", "central differences"}
        How C was obtained.
    newton_iterations : int
        Newton iterations that solved an implicit model (0 for an explicit one).
    """

    method: ClassVar[str] = "guf"

    input_names: tuple[str, ...]
    input_units: tuple[str, ...]
    input_estimate: np.ndarray
    input_standard_uncertainty: np.ndarray
    input_dof: np.ndarray
    input_covariance: np.ndarray
    input_ensemble: np.ndarray
    sensitivities: np.ndarray
    dof_effective: np.ndarray
    scalar_model: bool
    sensitivity_method: str
    newton_iterations: int

    def budget(self, output: int | str = 0) -> tuple[BudgetRow, ...]:
        """The uncertainty budget of one output (index or name), one row per input."""
        j = self._index(output)
        c = self.sensitivities[j]  # (N,)
        contrib = np.abs(c) * self.input_standard_uncertainty
        share = variance_shares(c, self.input_covariance)
        return tuple(
            BudgetRow(
                self.input_names[i],
                self.input_units[i],
                float(self.input_estimate[i]),
                float(self.input_standard_uncertainty[i]),
                float(c[i]),
                float(contrib[i]),
                float(self.input_dof[i]),
                float(share[i]),
            )
            for i in range(c.size)
        )

    def _per_output_dict(self) -> dict:
        """``dof_effective``: ν_eff per output (None for infinity)."""
        return {"dof_effective": [json_dof(v) for v in self.dof_effective]}

    def _method_dict(self) -> dict:
        """``sensitivity_method``, ``newton_iterations`` and ``budget``: each output name
        to its rows (values in ``unit``, full precision; ``display_unit`` is the unit a
        report shows them in; ``share`` as in :func:`variance_shares`)."""
        return {
            "sensitivity_method": self.sensitivity_method,
            "newton_iterations": self.newton_iterations,
            "budget": {
                self.names[j]: [
                    {
                        "input": r.input,
                        "unit": r.unit,
                        "display_unit": display_unit(r.unit),
                        "estimate": r.estimate,
                        "u": r.u,
                        "sensitivity": r.sensitivity,
                        "contribution": r.contribution,
                        "dof": json_dof(r.dof),
                        "share": r.share,
                    }
                    for r in self.budget(j)
                ]
                for j in range(len(self.names))
            },
        }


def welch_satterthwaite(sensitivities, covariance, dof, ensemble=None, names=None) -> float:
    """Effective degrees of freedom of one output, correlated ensembles allowed.

    Parameters
    ----------
    sensitivities : (N,) array_like
        c_i = ∂f/∂x_i.
    covariance : (N, N) array_like
        U_x.
    dof : (N,) array_like
        ν_i (inf allowed).
    ensemble : (N,) array_like of int, optional
        Ensemble number of each input, −1 for none (see :class:`.InputSet`).
    names : sequence of str, optional
        Input names for the error message.

    Returns
    -------
    float
        ν_eff = u_c⁴(y) / Σ_g v_g² / ν_g, inf when no finite-ν component contributes.

    Raises
    ------
    InputError
        Two contributing inputs are correlated, at least one of them has finite ν, and
        they are not in one ensemble (Welch–Satterthwaite does not apply).

    Notes
    -----
    u_c²(y) = c U_x cᵀ.  The components g are the single inputs outside ensembles,
    v_g = c_i² u²(x_i), and the ensembles, v_g = Σ_{a,b ∈ g} c_a c_b u(x_a, x_b) with ν_g
    the common ν of the members (Willink 2007, Result 2 and section 4.1.1).  Without
    ensembles and correlations this is JCGM 100:2008, G.4.1 (eq. G.2b).

    References
    ----------
    JCGM 100:2008, *Evaluation of measurement data — Guide to the expression of
    uncertainty in measurement*, annex G.4.

    Willink, R. (2007). A generalization of the Welch–Satterthwaite formula for use with
    correlated uncertainty components. *Metrologia* 44(5), 340–349.

    Examples
    --------
    GUM H.1.6: contributions 25 nm (ν = 18), 9.7 nm (ν = 25.6), 2.9 nm (ν = 50) and
    575 nm/°C × 0.029 °C (ν = 2) give ν_eff = 16.7, truncated to 16.

    >>> import numpy as np
    >>> u = np.array([25.0, 9.7, 2.9, 575 * 0.029])
    >>> round(float(welch_satterthwaite(np.ones(4), np.diag(u**2), [18, 25.6, 50, 2])), 1)
    16.7
    """
    c = np.asarray(sensitivities, dtype=float)
    cov = np.asarray(covariance, dtype=float)
    nu = np.asarray(dof, dtype=float)
    group = np.full(c.size, -1) if ensemble is None else np.asarray(ensemble, dtype=int)
    variance = float(c @ cov @ c)
    live = c != 0
    terms = cov * np.outer(c, c)  # c_a c_b u(x_a, x_b)
    coupled = (terms != 0) & ~np.eye(c.size, dtype=bool)
    finite = np.isfinite(nu)
    names = [f"x{i + 1}" for i in range(c.size)] if names is None else list(names)
    for a, b in zip(*np.nonzero(np.triu(coupled)), strict=True):
        if (finite[a] or finite[b]) and not (group[a] >= 0 and group[a] == group[b]):
            raise InputError(
                f"inputs {names[a]!r} and {names[b]!r} are correlated and one has finite "
                f"degrees of freedom ({nu[a]:g}, {nu[b]:g}) outside a common ensemble; "
                "Welch–Satterthwaite (JCGM 100 G.4.1) then does not apply: declare them an "
                "ensemble (estimated from the same observations), give them infinite dof, "
                "or use Monte Carlo"
            )
    denominator = 0.0
    for i in np.flatnonzero(live & finite & (group < 0)):
        denominator += terms[i, i] ** 2 / nu[i]
    for g in np.unique(group[live & finite & (group >= 0)]):
        members = np.flatnonzero(group == g)
        v_g = float(terms[np.ix_(members, members)].sum())
        denominator += v_g**2 / nu[members[0]]
    return math.inf if denominator == 0.0 else variance**2 / denominator


def _as_outputs(y) -> tuple[np.ndarray, bool]:
    y = np.asarray(y, dtype=float)
    if y.ndim == 0:
        return y.reshape(1), True
    if y.ndim != 1:
        raise InputError(
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
    """Solve h(y, x) = 0 for y by Newton's method on the least-squares core.

    Returns y (m,), C_y (m, m), C_x (m, N) or None when no Jacobian was given, and
    the number of iterations.

    Raises
    ------
    ConvergenceError
        If :func:`mtmetrology.optimize.solve_equations` stops without converging (its
        status message, the residual ‖h‖ and the number of steps are named).
    """
    y_start = np.atleast_1d(np.asarray(y0, dtype=float)).copy()
    m = y_start.size
    if not np.all(np.isfinite(y_start)):
        raise InputError("y0 contains NaN or inf")

    def c_y(yy):
        # Step relative to |y| (cube root of machine epsilon balances truncation and rounding).
        step = np.cbrt(np.finfo(float).eps) * np.maximum(np.abs(yy), 1.0)
        return _central_differences(
            lambda yp: h(yp, np.broadcast_to(x, (*yp.shape[:-1], x.size))), yy, step, m
        )

    def equations(yy):
        hv = np.asarray(h(yy, x), dtype=float).reshape(m)
        cy = jacobian(yy, x)[0] if jacobian is not None else c_y(yy)
        return hv, np.asarray(cy, dtype=float).reshape(m, m)

    solved = solve_equations(equations, y_start, rtol=tol, max_iter=max_iter)
    if not solved.success:
        raise ConvergenceError(
            f"implicit model: Newton's method did not solve h(y, x) = 0 ({solved.message}): "
            f"residual |h| = {np.linalg.norm(solved.residuals):.3g} at y = "
            f"{np.array2string(np.asarray(solved.x), precision=6)} after {solved.nit} steps; "
            "give a better y0"
        )
    y = np.asarray(solved.x, dtype=float)
    if jacobian is None:
        return y, c_y(y), None, solved.nit
    cy, cx = jacobian(y, x)
    cy = np.asarray(cy, dtype=float).reshape(m, m)
    return y, cy, np.asarray(cx, dtype=float).reshape(m, x.size), solved.nit


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
        (N, N) and ``dof`` (N,) (and optionally ``ensemble`` (N,)).
    jacobian : callable, optional
        Explicit: ``jacobian(x) -> (m, N)`` (or (N,) for a scalar output).
        Implicit: ``jacobian(y, x) -> (C_y (m, m), C_x (m, N))``.  Defaults to
        ``model.jacobian`` if present, else central differences.
    p : float
        Coverage probability, 0 < p < 1.
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
        Newton stopping rule and iteration limit of an implicit model: the ``rtol`` and
        ``max_iter`` of :func:`mtmetrology.optimize.solve_equations` (the step relative
        to the size of the terms of h).

    Returns
    -------
    GUFResult

    Raises
    ------
    InputError
        Invalid p, NaN estimates, an input of infinite variance, a model that
        returns NaN, an implicit model without y0, or correlated inputs with finite
        degrees of freedom outside a common ensemble (Welch–Satterthwaite does not apply).
    ConvergenceError
        Newton's method did not solve an implicit model (iteration limit, no descent, or
        C_y singular at y0); the message names the residual ‖h‖ and the steps taken.

    Notes
    -----
    U_y = C U_x Cᵀ (JCGM 102:2011, 6.2.1.3; JCGM 100:2008, 5.2.2 for m = 1).
    Explicit: C = ∂f/∂x at x.  Implicit: C = −C_y⁻¹ C_x with C_y = ∂h/∂Y, C_x = ∂h/∂X
    (JCGM 102:2011, 6.2.2).  Numerical sensitivities use central differences with
    step u(x_j) (JCGM 100:2008, 5.1.3 note 2); inputs with zero variance are skipped
    (sensitivity 0: they contribute nothing).
    ν_eff by Welch–Satterthwaite (JCGM 100:2008, G.4.1), an ensemble of correlated inputs
    counted as one component (Willink 2007), see :func:`welch_satterthwaite`;
    k = t_{(1+p)/2, ν_eff}.  The hyper-ellipsoid factor is k_p = sqrt(χ²_m(p)) (JCGM
    102:2011, 6.5.2.3).

    References
    ----------
    JCGM 100:2008, *Evaluation of measurement data — Guide to the expression of
    uncertainty in measurement* (GUM), clauses 5 and 6, annexes G and H.

    JCGM 102:2011, *Evaluation of measurement data — Supplement 2 to the GUM — Extension
    to any number of output quantities*, clause 6.

    Willink, R. (2007). A generalization of the Welch–Satterthwaite formula for use with
    correlated uncertainty components. *Metrologia* 44(5), 340–349.

    Examples
    --------
    GUM H.2 (JCGM 100:2008, Table H.4): resistance, reactance and impedance from five
    simultaneous observations of V, I and φ; the inputs form one ensemble of ν = 4.

    >>> import numpy as np
    >>> from mtmetrology.uncertainty.inputs import InputSet
    >>> obs = [[5.007, 19.663e-3, 1.0456], [4.994, 19.639e-3, 1.0438],
    ...        [5.005, 19.640e-3, 1.0468], [4.990, 19.685e-3, 1.0428],
    ...        [4.999, 19.678e-3, 1.0433]]
    >>> inputs = InputSet.from_observations(["V", "I", "phi"], obs, ["", "", "rad"])
    >>> def rxz(x):
    ...     z = x[..., 0] / x[..., 1]
    ...     return np.stack([z * np.cos(x[..., 2]), z * np.sin(x[..., 2]), z], axis=-1)
    >>> r = guf(rxz, inputs, output_names=["R", "X", "Z"], output_units=["ohm"] * 3)
    >>> for o in r.outputs:
    ...     print(f"{o.name} = {o.value:.3f} {o.unit}, u = {o.u:.2f}")
    R = 127.732 ohm, u = 0.07
    X = 219.847 ohm, u = 0.30
    Z = 254.260 ohm, u = 0.24
    >>> [round(float(v), 3) for v in r.correlation[[0, 0, 1], [1, 2, 2]]]
    [-0.588, -0.485, 0.993]
    >>> [round(float(v), 9) for v in r.dof_effective]
    [4.0, 4.0, 4.0]
    """
    if not 0.0 < p < 1.0:
        raise InputError(f"p must lie in (0, 1), got {p}")
    x = np.asarray(inputs.estimate, dtype=float)
    ux_cov = np.asarray(inputs.covariance, dtype=float)
    names_in = list(inputs.names)
    if not np.all(np.isfinite(x)):
        bad = [names_in[i] for i in np.flatnonzero(~np.isfinite(x))]
        raise InputError(f"input estimates must be finite; NaN/inf for {bad}")
    u_x = np.sqrt(np.diag(ux_cov))
    if not np.all(np.isfinite(u_x)):
        bad = [names_in[i] for i in np.flatnonzero(~np.isfinite(u_x))]
        raise InputError(
            f"inputs {bad} have infinite variance (e.g. Student t with dof <= 2); "
            "the GUF cannot propagate them, use Monte Carlo"
        )
    if jacobian is None:
        jacobian = getattr(model, "jacobian", None) if not implicit else None

    iterations = 0
    if implicit:
        if y0 is None:
            raise InputError("an implicit model needs a starting point y0")
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
        raise InputError(f"the model returned a non-finite estimate {y} at the input estimates")
    if not np.all(np.isfinite(sens)):
        raise InputError("non-finite sensitivity coefficients; check the model near the estimates")

    cov = sens @ ux_cov @ sens.T  # (m, m)
    cov = 0.5 * (cov + cov.T)
    u_y = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    live = u_y > 0
    corr = np.eye(m)
    corr[np.ix_(live, live)] = cov[np.ix_(live, live)] / np.outer(u_y[live], u_y[live])
    lam_max = float(np.linalg.eigvalsh(corr)[-1])

    dof_in = np.asarray(inputs.dof, dtype=float)
    ensemble = np.asarray(getattr(inputs, "ensemble", np.full(x.size, -1)), dtype=int)
    nu_eff = np.array(
        [welch_satterthwaite(sens[j], ux_cov, dof_in, ensemble, names_in) for j in range(m)]
    )
    k = np.array([_t_factor(p, nu, truncate_dof) for nu in nu_eff])
    expanded = k * u_y
    interval = np.stack([y - expanded, y + expanded], axis=-1)  # (m, 2)

    return GUFResult(
        names=tuple(output_labels(output_names, getattr(model, "output_names", None), m, "y")),
        units=tuple(output_labels(output_units, getattr(model, "output_units", None), m, "")),
        input_names=tuple(names_in),
        input_units=tuple(inputs.units),
        input_estimate=x,
        input_standard_uncertainty=u_x,
        input_dof=dof_in,
        input_covariance=ux_cov,
        input_ensemble=ensemble,
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
        scalar_model=bool(scalar),
        sensitivity_method="analytic" if jacobian is not None else "central differences",
        newton_iterations=iterations,
    )


def _t_factor(p: float, nu: float, truncate: bool) -> float:
    from scipy import stats  # here, not at the top: importing it takes 0.5 s

    q = 0.5 * (1.0 + p)
    if math.isinf(nu):
        return float(stats.norm.ppf(q))
    if truncate and nu >= 1.0:
        # Rounding noise must not drop an integer ν (an ensemble of ν = 4 gives 3.9999…).
        nu = math.floor(nu * (1.0 + 1e-9))
    return float(stats.t.ppf(q, nu))
