"""Weighted non-linear least squares (Gauss–Newton) with rank and conditioning checks.

The identification engine of mtmetrology: any problem object exposing ``names``,
``n_rows`` and ``evaluate(x, jacobian=True) -> (r, J)`` (weighted residuals and their
Jacobian) is solved by Gauss–Newton with column scaling (seed 004 §3.6, seed 000
eqs 5-4…5-6)::

    J_s = J · D⁻¹,   D = diag(‖J_:,j‖)         (unit-norm columns)
    Δx  = −D⁻¹ · J_s⁺ r                          (least-squares step, SVD)

A rank-deficient Jacobian stops the solve with an error that names the unidentifiable
combinations (no silent minimum-norm answer).  The covariance of the estimate is
``(JᵀJ)⁻¹`` of the weighted problem (the weights carry the input uncertainties), and the
a-posteriori variance factor ``s² = ‖r‖²/(m − n)`` is reported beside it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology.identification.diagnostics import IdentifiabilityReport, analyse_identifiability
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

__all__ = ["IdentificationError", "IdentificationResult", "gauss_newton"]


class IdentificationError(ValueError):
    """The identification cannot be solved; the message says why and what to do."""


@dataclass(frozen=True)
class IdentificationResult:
    """Result of :func:`gauss_newton`.

    Attributes
    ----------
    names : tuple of str
    estimate : ndarray, shape (n,)
        Unknowns in internal units.
    covariance : ndarray, shape (n, n)
        ``(JᵀJ)⁻¹`` of the weighted problem at the solution.
    residuals : ndarray, shape (m,)
        Weighted residuals at the solution.
    variance_factor : float
        ``‖r‖²/(m − n)``; ≈ 1 when the weights are the true input uncertainties.
    iterations : int
    converged : bool
    diagnostics : IdentifiabilityReport
    message : str
    """

    names: tuple[str, ...]
    estimate: np.ndarray
    covariance: np.ndarray
    residuals: np.ndarray
    variance_factor: float
    iterations: int
    converged: bool
    diagnostics: IdentifiabilityReport
    message: str

    @property
    def standard_uncertainties(self) -> np.ndarray:
        return np.sqrt(np.diag(self.covariance))

    def parameter_set(self, machine: Machine, provenance: dict | None = None) -> ParameterSet:
        """The machine's error parameters with their covariance (nuisance unknowns dropped).

        Dropping the ball and tool unknowns does not change the statistics of the
        parameters (seed 000 §5: the 13 of 31 outputs keep their covariance block).
        """
        missing = [n for n in machine.parameter_names if n not in self.names]
        if missing:
            raise ValueError(f"the identification has no unknown {', '.join(missing)}")
        idx = [self.names.index(n) for n in machine.parameter_names]
        return ParameterSet(
            machine.parameter_names,
            self.estimate[idx],
            machine.parameter_units,
            self.covariance[np.ix_(idx, idx)],
            {"message": self.message, **(provenance or {})},
        )


def gauss_newton(
    problem,
    x0: np.ndarray | None = None,
    *,
    xtol: float = 1e-8,
    max_iter: int = 50,
    rtol_rank: float = 1e-8,
) -> IdentificationResult:
    """Solve a weighted non-linear least-squares problem by Gauss–Newton.

    Parameters
    ----------
    problem : object
        Exposes ``names``, ``evaluate(x, jacobian=True)`` and optionally ``initial()``.
    x0 : ndarray, optional
        Starting point; ``problem.initial()`` when omitted.
    xtol : float
        Stop when the scaled step ``‖D Δx‖`` is below ``xtol``.  D makes every column
        unit-norm, so this is a step in units of the residual weights (input standard
        uncertainties): 1e-8 is far below any meaningful change and above the rounding
        noise of positions of a few hundred mm.
    max_iter : int
    rtol_rank : float
        Rank tolerance of the column-scaled Jacobian.

    Returns
    -------
    IdentificationResult

    Raises
    ------
    IdentificationError
        If the Jacobian is rank deficient (the message names the confounded unknowns)
        or the residuals are not finite.
    """
    x = np.array(problem.initial() if x0 is None else x0, dtype=float)
    names = tuple(problem.names)
    converged = False
    it = 0
    for it in range(1, max_iter + 1):
        r, jac = problem.evaluate(x, jacobian=True)
        if not (np.all(np.isfinite(r)) and np.all(np.isfinite(jac))):
            raise IdentificationError("residuals or Jacobian are not finite at the current point")
        norms = np.linalg.norm(jac, axis=0)
        if it == 1:
            report = analyse_identifiability(jac, names, rtol=rtol_rank)
            if not report.full_rank:
                raise IdentificationError(
                    f"the identification is rank deficient ({report.message}); remove one "
                    "parameter of each confounded group or add measurements that separate them"
                )
        scaled = jac / norms
        step, *_ = np.linalg.lstsq(scaled, -r, rcond=None)
        x = x + step / norms
        if np.linalg.norm(step) <= xtol:
            converged = True
            break
    r, jac = problem.evaluate(x, jacobian=True)
    report = analyse_identifiability(jac, names, rtol=rtol_rank)
    norms = np.linalg.norm(jac, axis=0)
    scaled = jac / norms
    inv = np.linalg.pinv(scaled.T @ scaled)
    cov = inv / np.outer(norms, norms)
    dof = r.size - x.size
    vf = float(r @ r / dof) if dof > 0 else float("nan")
    message = (
        f"converged in {it} iterations" if converged else f"not converged after {it} iterations"
    )
    return IdentificationResult(
        names=names,
        estimate=x,
        covariance=cov,
        residuals=r,
        variance_factor=vf,
        iterations=it,
        converged=converged,
        diagnostics=report,
        message=f"{message}; {report.message}",
    )
