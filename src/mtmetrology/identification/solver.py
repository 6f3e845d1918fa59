"""Identification: the weighted non-linear least squares of machine errors, with diagnostics.

Any problem object exposing ``names``, ``n_rows`` and ``evaluate(x, jacobian=True) -> (r,
J)`` (weighted residuals and their Jacobian), optionally ``initial()`` and
``residual_rounding``, is solved by the project's least-squares core
(:func:`mtmetrology.optimize.least_squares`: Gauss–Newton with column scaling and a
Levenberg–Marquardt safeguard; Alami Mchichi (2018), Ch. 5; Sepahi Boroujeni (2021), eqs 5-4…5-6)::

    J_s = J · D⁻¹,   D = diag(‖J_:,j‖)         (unit-norm columns)
    Δx  = −D⁻¹ · J_s⁺ r                          (least-squares step, SVD)

A rank-deficient Jacobian is refused with a :class:`~mtmetrology.errors.RankDeficientError`
that names the unidentifiable combinations, unless the minimum-norm solution is asked
for explicitly (then it is flagged in the result).  The covariance of the estimate is
``(JᵀJ)⁻¹`` of the weighted problem (the weights carry the input uncertainties; Sepahi
Boroujeni (2021), eq. 5-6); the a-posteriori variance factor ``s² = ‖r‖²/(m − n)`` is
reported beside it when the problem has redundancy (m > n).
:meth:`IdentificationResult.with_adequacy` applies the one model-adequacy rule of every
application (:mod:`mtmetrology.identification.adequacy`: the chi-squared test of the
residuals, the covariance scaled by s² when they contradict the stated noise).  The SVD
of the last accepted iterate serves the step, the rank, the condition number, the
observability indices and the covariance: it is computed once per accepted point, never
again for the diagnostics.

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, eqs 5-4–5-6 (SAMBA Gauss–Newton).
Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes : configuration
optimisée des artefacts et de la séquence de mesure de la méthode SAMBA en vue d'une
estimation efficace des erreurs géométriques*. PhD thesis, École Polytechnique de
Montréal, Ch. 5.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from mtmetrology.display import NotebookRepr
from mtmetrology.errors import InputError, RankDeficientError
from mtmetrology.identification.adequacy import SIGNIFICANCE, ModelAdequacy, model_adequacy
from mtmetrology.identification.diagnostics import IdentifiabilityReport, analyse_identifiability
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.optimize import STATUS_MESSAGES, Status, least_squares

__all__ = ["IdentificationError", "IdentificationResult", "levenberg_marquardt"]

#: Former name of the rank-deficiency error of an identification.
IdentificationError = RankDeficientError


@dataclass(frozen=True, eq=False)
class IdentificationResult(NotebookRepr):
    """Result of :func:`levenberg_marquardt`.

    Attributes
    ----------
    names : tuple of str
        The unknowns.
    estimate : (n,) ndarray
        Unknowns in internal units.
    covariance : (n, n) ndarray
        ``(JᵀJ)⁻¹`` of the weighted problem at the estimate (internal units); the
        pseudo-inverse over the rank for a minimum-norm solution.
    residuals : (m,) ndarray
        Weighted residuals at the estimate.
    jacobian : (m, n) ndarray
        Their Jacobian.
    cost : float
        ``½‖r‖²``.
    dof : int
        Redundancy ``m − rank``.
    variance_factor : float or None
        ``‖r‖²/(m − n)``, ≈ 1 when the weights are the true input uncertainties; None
        when there is no redundancy (m ≤ n).
    nit, nfev, njev : int
        Iterations, residual and Jacobian evaluations.
    status : int
        :class:`mtmetrology.optimize.Status` code of the solve.
    minimum_norm : bool
        True when a rank-deficient problem was solved by its minimum-norm solution.
    diagnostics : IdentifiabilityReport
        Rank, condition numbers, observability indices, null directions at the estimate.
    adequacy : ModelAdequacy or None
        The chi-squared test of the residuals and the covariance factor it led to, once
        :meth:`with_adequacy` has applied the rule (None before: ``covariance`` is then the
        a-priori one).
    """

    names: tuple[str, ...]
    estimate: np.ndarray
    covariance: np.ndarray = field(repr=False)
    residuals: np.ndarray = field(repr=False)
    jacobian: np.ndarray = field(repr=False)
    cost: float
    dof: int
    variance_factor: float | None
    nit: int
    nfev: int
    njev: int
    status: int
    minimum_norm: bool
    diagnostics: IdentifiabilityReport = field(repr=False)
    adequacy: ModelAdequacy | None = None

    @property
    def success(self) -> bool:
        return self.status > 0

    @property
    def message(self) -> str:
        text = f"{STATUS_MESSAGES[Status(self.status)]} after {self.nit} iterations"
        if self.minimum_norm:
            text += "; MINIMUM-NORM solution of a rank-deficient problem"
        return f"{text}; {self.diagnostics.message}"

    @property
    def standard_uncertainty(self) -> np.ndarray:
        """Square roots of the diagonal of :attr:`covariance`, internal units."""
        return np.sqrt(np.diag(self.covariance))

    def value(self, name: str) -> float:
        """Estimate of the unknown ``name``, internal units."""
        return float(self.estimate[self._position(name)])

    def u(self, name: str) -> float:
        """Standard uncertainty of the unknown ``name``, internal units."""
        return float(np.sqrt(self.covariance[(i := self._position(name)), i]))

    def _position(self, name: str) -> int:
        if name not in self.names:
            raise InputError(f"{name!r}: not an unknown of this identification")
        return self.names.index(name)

    def with_adequacy(
        self, rule: str = "scale", alpha: float = SIGNIFICANCE
    ) -> IdentificationResult:
        """The result with the model-adequacy rule applied (the one rule of every application).

        ``s² = ‖r‖²/ν``, ν = m − rank, ``p = P(χ²_ν ≥ ‖r‖²)``; when ``p < alpha`` and
        ``rule == "scale"`` the covariance is multiplied by s² (Birge ratio squared,
        :func:`~mtmetrology.identification.adequacy.model_adequacy`).

        Parameters
        ----------
        rule : {"scale", "a-priori"}
        alpha : float

        Returns
        -------
        IdentificationResult
            With :attr:`adequacy` set and the covariance scaled when the rule says so.

        Raises
        ------
        InputError
            An unknown rule or a bad alpha; the rule applied twice.
        """
        if self.adequacy is not None:
            raise InputError("the model-adequacy rule has already been applied to this result")
        chi2 = float(self.residuals @ self.residuals)
        found = model_adequacy(chi2, self.dof, rule=rule, alpha=alpha)
        return replace(self, covariance=self.covariance * found.factor, adequacy=found)

    def parameter_set(self, machine: Machine, provenance: dict | None = None) -> ParameterSet:
        """The machine's error parameters with their covariance (nuisance unknowns dropped).

        Dropping the ball and tool unknowns does not change the statistics of the
        parameters (Sepahi Boroujeni (2021), Ch. 5: the 13 of 31 outputs keep their covariance
        block).
        """
        missing = [n for n in machine.parameter_names if n not in self.names]
        if missing:
            raise InputError(f"the identification has no unknown {', '.join(missing)}")
        idx = [self.names.index(n) for n in machine.parameter_names]
        return ParameterSet(
            machine.parameter_names,
            self.estimate[idx],
            machine.parameter_units,
            self.covariance[np.ix_(idx, idx)],
            {
                "identification": self.message,
                **({} if self.adequacy is None else {"adequacy": self.adequacy.to_dict()}),
                **(provenance or {}),
            },
            machine=machine.name,
            model=machine.model_name,
        )

    def parameter_set_keys(self, machine: Machine, provenance: dict | None = None) -> dict:
        """The keys a calibration result embeds (``model``, ``parameters``, ``covariance``,
        ``provenance`` of :meth:`parameter_set`'s document), so that it is read as a
        parameter set; a minimum-norm solution states no covariance (its u is undefined)."""
        pset = self.parameter_set(machine, provenance)
        if self.minimum_norm:
            pset = replace(pset, covariance=None)
        doc = pset.to_document()
        return {k: doc[k] for k in ("model", "parameters", "covariance", "provenance") if k in doc}


def levenberg_marquardt(
    problem,
    x0: np.ndarray | None = None,
    *,
    xtol: float = 1e-8,
    max_iter: int = 50,
    rank_rtol: float = 1e-8,
    minimum_norm: bool = False,
    report_names=None,
) -> IdentificationResult:
    """Solve a weighted non-linear least-squares identification by Levenberg–Marquardt.

    The project's damped core, :func:`mtmetrology.optimize.least_squares`, runs: undamped
    Gauss–Newton steps while they lower the cost, Levenberg–Marquardt damping in the
    column-scaled coordinates when they do not (see :mod:`mtmetrology.optimize`); then the
    identifiability of the unknowns is analysed on the SVD of the last accepted point.

    Parameters
    ----------
    problem : object
        Exposes ``names``, ``evaluate(x, jacobian=True) -> (r, J)`` and optionally
        ``initial()`` and ``residual_rounding`` (the rounding unit of one weighted
        residual, for the rounding-level stop of the core).
    x0 : ndarray, optional
        Starting point; ``problem.initial()`` when omitted.
    xtol : float
        Stop when the scaled step ``‖D Δx‖`` is below ``xtol``.  D makes every column
        unit-norm, so this is a step in units of the residual weights (input standard
        uncertainties): 1e-8 is far below any meaningful change and above the rounding
        noise of positions of a few hundred mm.
    max_iter : int
    rank_rtol : float
        Rank tolerance of the column-scaled Jacobian.
    minimum_norm : bool
        Solve a rank-deficient problem by its minimum-norm solution instead of refusing
        it; the result says so (``minimum_norm``) and its covariance is the pseudo-inverse.
    report_names : sequence of str, optional
        The unknowns whose confounding matters (e.g. the machine parameters): messages list
        the null directions that touch them.

    Returns
    -------
    IdentificationResult
        A solve that stops without converging is returned, not raised: read ``status``
        and ``success``.

    Raises
    ------
    RankDeficientError
        If the Jacobian is rank deficient at the start or at the solution and
        ``minimum_norm`` is False; ``confounded`` lists the names of each combination.

    Examples
    --------
    >>> import numpy as np
    >>> class Line:                       # y = a + b t, three exact points
    ...     names = ("a", "b")
    ...     t = np.array([0.0, 1.0, 2.0])
    ...     def initial(self):
    ...         return np.zeros(2)
    ...     def evaluate(self, x, jacobian=True):
    ...         r = x[0] + x[1] * self.t - (1.0 + 2.0 * self.t)
    ...         return r, np.column_stack([np.ones(3), self.t])
    >>> res = levenberg_marquardt(Line())
    >>> res.success, np.round(res.estimate, 12).tolist(), res.dof
    (True, [1.0, 2.0], 1)

    The NIST StRD problem Misra1a from its second start (250, 5e-4), unweighted: the
    certified residual standard deviation is 1.0187876330E-01 and the standard deviation of
    b1 is 2.7070075241E+00 (``s·sqrt((JᵀJ)⁻¹)``, s² the variance factor).

    >>> class Misra1a:
    ...     names = ("b1", "b2")
    ...     x = np.array([77.6, 114.9, 141.1, 190.8, 239.9, 289.0, 332.8, 378.4, 434.8,
    ...                   477.3, 536.8, 593.1, 689.1, 760.0])
    ...     y = np.array([10.07, 14.73, 17.94, 23.93, 29.61, 35.18, 40.02, 44.82, 50.76,
    ...                   55.05, 61.01, 66.40, 75.47, 81.78])
    ...     def initial(self):
    ...         return np.array([250.0, 5e-4])
    ...     def evaluate(self, b, jacobian=True):
    ...         e = np.exp(-b[1] * self.x)
    ...         return b[0] * (1 - e) - self.y, np.column_stack([1 - e, b[0] * self.x * e])
    >>> res = levenberg_marquardt(Misra1a())
    >>> s = np.sqrt(res.variance_factor)
    >>> f"{res.estimate[0]:.8f}", f"{s:.10e}", f"{s * res.standard_uncertainty[0]:.10e}"
    ('238.94212918', '1.0187876330e-01', '2.7070075241e+00')

    References
    ----------
    Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
    Tool Metrology*. PhD thesis, Polytechnique Montréal, eqs 5-4–5-6.
    Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes : configuration
    optimisée des artefacts et de la séquence de mesure de la méthode SAMBA en vue d'une
    estimation efficace des erreurs géométriques*. PhD thesis, École Polytechnique de
    Montréal, Ch. 5.
    NIST Statistical Reference Datasets, Nonlinear Regression, "Misra1a" (D. Misra, NIST,
    1978).
    """
    names = tuple(problem.names)
    start = np.array(problem.initial() if x0 is None else x0, dtype=float)
    solve = least_squares(
        lambda x: problem.evaluate(x, jacobian=True),
        start,
        xtol=xtol,
        max_iter=max_iter,
        residual_rounding=float(getattr(problem, "residual_rounding", 0.0)),
        rank_rtol=rank_rtol,
        require_full_rank=not minimum_norm,
    )
    report = analyse_identifiability(
        solve.jacobian,
        names,
        rtol=rank_rtol,
        report_names=report_names,
        svd=(solve.column_norms, solve.singular_values, solve.right_singular_vectors),
    )
    if not report.full_rank and not minimum_norm:
        raise RankDeficientError(
            f"the identification is rank deficient ({report.message}); remove one parameter "
            "of each confounded group or add measurements that separate them",
            confounded=report.confounded(),
        )
    r = solve.residuals
    m = r.size
    dof = m - solve.rank
    return IdentificationResult(
        names=names,
        estimate=np.asarray(solve.x, dtype=float),
        covariance=solve.covariance(),
        residuals=r,
        jacobian=solve.jacobian,
        cost=solve.cost,
        dof=dof,
        variance_factor=float(r @ r / dof) if dof > 0 else None,
        nit=solve.nit,
        nfev=solve.nfev,
        njev=solve.njev,
        status=solve.status,
        minimum_norm=not report.full_rank,
        diagnostics=report,
    )
