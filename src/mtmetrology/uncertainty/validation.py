"""Validation of the GUM uncertainty framework by Monte Carlo (JCGM 101 §8, JCGM 102 §8).

GUF results (an estimate and a covariance, from any source) are compared with an
:class:`~mtmetrology.uncertainty.mcm.MCMResult`; every compared quantity is a row with
the difference, its numerical tolerance and their ratio, and the GUF is validated when
every row passes.

- One output (JCGM 101:2008, 8.2): d_low = |y − U(y) − y_low|, d_high = |y + U(y) − y_high|,
  with y ± U(y) the GUF interval and [y_low, y_high] the probabilistically symmetric MCM
  interval, each against δ.
- m > 1 outputs (JCGM 102:2011, 8; Sepahi Boroujeni 2021, eqs. 7-3, 7-4): d_y = |y_GUF − y_MCM| and
  d_u = |u_GUF − u_MCM| per output against δ, d_λ = |λ_max,GUF − λ_max,MCM| against ρ,
  d_k = |k_p,GUF − k_p,MCM| against κ_p.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mtmetrology.display import NotebookRepr
from mtmetrology.errors import InputError
from mtmetrology.uncertainty.mcm import (
    MCMResult,
    NumericalTolerance,
    check_tolerance,
    numerical_tolerance,
)
from mtmetrology.uncertainty.regions import normal_ellipsoidal_coverage_factor

__all__ = [
    "NumericalTolerance",
    "ValidationReport",
    "ValidationRow",
    "validate_guf",
    "validate_results",
]


@dataclass(frozen=True)
class ValidationRow:
    """One compared quantity: ``difference = |guf − mcm|`` against ``tolerance``."""

    name: str
    quantity: str
    guf: float
    mcm: float
    difference: float
    tolerance: float

    @property
    def ratio(self) -> float:
        """difference / tolerance (≤ 1 passes; Sepahi Boroujeni 2021, Table 7-1 prints it in %)."""
        return self.difference / self.tolerance

    @property
    def passed(self) -> bool:
        return bool(self.difference <= self.tolerance)

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "quantity": self.quantity,
            "guf": self.guf,
            "mcm": self.mcm,
            "difference": self.difference,
            "tolerance": self.tolerance,
            "ratio": self.ratio,
            "passed": self.passed,
        }


@dataclass(frozen=True)
class ValidationReport(NotebookRepr):
    """The rows of a GUF-by-MCM validation, the verdict and a one-line message."""

    rows: tuple[ValidationRow, ...]
    p: float
    procedure: str
    message: str

    @property
    def passed(self) -> bool:
        """True when every row is within its tolerance (the GUF is validated)."""
        return all(row.passed for row in self.rows)

    @property
    def failed(self) -> tuple[ValidationRow, ...]:
        """The rows outside their tolerance."""
        return tuple(row for row in self.rows if not row.passed)

    def to_dict(self) -> dict:
        """JSON-ready form, as stored under ``validation`` in result files."""
        return {
            "procedure": self.procedure,
            "p": self.p,
            "passed": self.passed,
            "message": self.message,
            "rows": [row.to_dict() for row in self.rows],
        }

    def to_text(self) -> str:
        """A plain-text table, one line per row, and the verdict."""
        header = ("output", "quantity", "GUF", "MCM", "|difference|", "tolerance", "ratio", "")
        lines = [
            (
                row.name,
                row.quantity,
                _format_value(row.guf, row.tolerance),
                _format_value(row.mcm, row.tolerance),
                f"{row.difference:.3g}",
                f"{row.tolerance:.3g}",
                f"{100 * row.ratio:.0f} %",
                "ok" if row.passed else "FAIL",
            )
            for row in self.rows
        ]
        widths = [max(len(cells[i]) for cells in [header, *lines]) for i in range(len(header))]
        render = [
            "  ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True)).rstrip()
            for cells in [header, *lines]
        ]
        return "\n".join([*render, self.message])

    def to_rich(self):
        """A ``rich.table.Table`` of the rows, failing rows in red."""
        from rich.table import Table

        table = Table(title=f"GUF validation ({self.procedure})", caption=self.message)
        for column in ("output", "quantity", "GUF", "MCM", "|difference|", "tolerance", "ratio"):
            table.add_column(
                column, justify="left" if column in ("output", "quantity") else "right"
            )
        for row in self.rows:
            table.add_row(
                row.name,
                row.quantity,
                _format_value(row.guf, row.tolerance),
                _format_value(row.mcm, row.tolerance),
                f"{row.difference:.3g}",
                f"{row.tolerance:.3g}",
                f"{100 * row.ratio:.0f} %",
                style=None if row.passed else "red",
            )
        return table

    def __str__(self) -> str:
        return self.to_text()


def _format_value(value: float, tolerance: float) -> str:
    """Fixed-point with one decimal beyond the tolerance's, so large values keep the digits
    that the comparison is about (50000771.3 nm against δ = 0.5 nm, not 5.00008e+07)."""
    if not (np.isfinite(tolerance) and tolerance > 0):
        return f"{value:.6g}"
    decimals = max(0, 1 - int(np.floor(np.log10(tolerance))))
    return f"{value:.{decimals}f}"


def _row(name: str, quantity: str, guf, mcm, tolerance) -> ValidationRow:
    guf, mcm = float(guf), float(mcm)
    return ValidationRow(name, quantity, guf, mcm, abs(guf - mcm), float(tolerance))


def _largest_eigenvalue(covariance: np.ndarray) -> float:
    u = np.sqrt(np.diag(covariance))
    if np.any(u <= 0):
        raise ValueError("guf_covariance has a zero variance: its correlation is undefined")
    return float(np.linalg.eigvalsh(covariance / np.outer(u, u))[-1])


def validate_guf(
    guf_estimate,
    guf_covariance,
    mcm: MCMResult,
    *,
    tolerance,
    p: float = 0.95,
    guf_coverage_factor: float | None = None,
    guf_interval=None,
    names: Sequence[str] | None = None,
) -> ValidationReport:
    """Validate GUF results against a Monte Carlo result.

    Parameters
    ----------
    guf_estimate : (m,) array or float
        GUF estimate y, in the units of the MCM outputs.
    guf_covariance : (m, m) array or float
        GUF covariance U_y (a variance u² for one output).
    mcm : MCMResult
        Monte Carlo result of the same model, run with the same p.
    tolerance : float, (m,) array or NumericalTolerance
        δ per output (output units); a :class:`Tolerance` also gives ρ and κ_p, otherwise
        they follow from two significant digits of the MCM λ_max and k_p (JCGM 101, 7.9.2:
        λ_max = 1.313 → ρ = 0.05, k_p = 3.55 → κ_p = 0.05, as in Sepahi Boroujeni 2021, Ch. 7).
    p : float
        Coverage probability; must equal ``mcm.p``.
    guf_coverage_factor : float, optional
        One output: k of the GUF interval y ± k u (default Φ⁻¹((1 + p)/2), 1.96 for
        p = 0.95; pass the t-factor for finite effective degrees of freedom). m > 1: the
        GUF k_p (default sqrt(χ²_m(p)), JCGM 102, 6.5.2.3).
    guf_interval : (2,) array, optional
        One output: the GUF coverage interval itself (overrides ``guf_coverage_factor``).
    names : sequence of str, optional
        Output names for the rows ("Y" or "Y1", "Y2", … by default).

    Returns
    -------
    ValidationReport

    Raises
    ------
    ValueError
        Shapes that disagree with ``mcm``, a covariance that is not symmetric with a
        non-negative diagonal, a tolerance that is not positive, p different from ``mcm.p``.

    Notes
    -----
    JCGM 101:2008, 8.2 (one output): d_low = |y − U(y) − y_low|, d_high = |y + U(y) −
    y_high|, validated if both ≤ δ. JCGM 102:2011, 8 and Sepahi Boroujeni (2021), eqs.
    7-3/7-4 (m > 1): d_y, d_u ≤ δ element-wise, d_λ ≤ ρ, d_k ≤ κ_p.

    References
    ----------
    JCGM 101:2008, *Evaluation of measurement data — Supplement 1 to the GUM — Propagation
    of distributions using a Monte Carlo method*, clause 8.

    JCGM 102:2011, *Evaluation of measurement data — Supplement 2 to the GUM — Extension
    to any number of output quantities*, clause 8.

    Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
    Tool Metrology*. PhD thesis, Polytechnique Montréal, eqs. 7-3, 7-4 and Tables 7-1, 7-2.

    Examples
    --------
    JCGM 101:2008, 9.3 (mass calibration, Table 6): the GUF gives δm = 1.2340 mg with
    u = 0.0539 mg; Monte Carlo u = 0.0754 mg, and the interval ends differ by about
    0.04 mg (published 0.0451 and 0.0430) against δ = 0.0005 mg: not validated.

    >>> import numpy as np
    >>> from mtmetrology.uncertainty import InputQuantity, InputSet, Normal, Rectangular
    >>> from mtmetrology.uncertainty.mcm import monte_carlo
    >>> def mass(x):
    ...     m, dm, rho_a, rho_w, rho_r = x.T
    ...     return (m + dm) * (1 + (rho_a - 1.2) * (1 / rho_w - 1 / rho_r)) - 100_000.0
    >>> inputs = InputSet([
    ...     InputQuantity("m_Rc", Normal(100_000.0, 0.050)),
    ...     InputQuantity("dm_Rc", Normal(1.234, 0.020)),
    ...     InputQuantity("rho_a", Rectangular(1.10, 1.30)),
    ...     InputQuantity("rho_W", Rectangular(7000.0, 9000.0)),
    ...     InputQuantity("rho_R", Rectangular(7950.0, 8050.0))])
    >>> r = monte_carlo(mass, inputs, trials=10**6, seed=1)
    >>> round(r.output().u, 4)
    0.0754
    >>> report = validate_guf(1.234, 0.05**2 + 0.02**2, r, tolerance=0.0005)
    >>> [round(row.difference, 2) for row in report.rows], report.passed
    ([0.04, 0.04], False)
    """
    from scipy import stats  # here, not at the top: importing it takes 0.5 s

    m = mcm.m
    p = float(p)
    if not 0.0 < p < 1.0:
        raise ValueError(f"p must lie strictly between 0 and 1, got {p}")
    if abs(p - mcm.p) > 1e-12:
        raise ValueError(f"p={p} differs from the p={mcm.p} the Monte Carlo result was run with")
    estimate = np.asarray(guf_estimate, dtype=float).reshape(-1)
    covariance = np.asarray(guf_covariance, dtype=float)
    if estimate.shape != (m,) or covariance.size != m * m:
        raise ValueError(
            f"guf_estimate must have {m} entries and guf_covariance {m}x{m} to match the "
            f"Monte Carlo result, got {np.shape(guf_estimate)} and {np.shape(guf_covariance)}"
        )
    covariance = covariance.reshape(m, m)
    if not (np.all(np.isfinite(estimate)) and np.all(np.isfinite(covariance))):
        raise ValueError("guf_estimate and guf_covariance must be finite")
    if not np.allclose(covariance, covariance.T, rtol=1e-10, atol=0.0) or np.any(
        np.diag(covariance) < 0
    ):
        raise ValueError("guf_covariance must be symmetric with a non-negative diagonal")
    tolerance = check_tolerance(tolerance)
    if tolerance is None:
        raise ValueError("tolerance is required: δ, a per-output array, or a NumericalTolerance")
    delta = tolerance.for_outputs(m)
    if names is None:
        names = ["Y"] if m == 1 else [f"Y{j + 1}" for j in range(m)]
    names = [str(name) for name in names]
    if len(names) != m:
        raise ValueError(f"names has {len(names)} entries for {m} outputs")
    u = np.sqrt(np.diag(covariance))

    if m == 1:
        if guf_interval is not None:
            interval = np.asarray(guf_interval, dtype=float).reshape(-1)
            if interval.shape != (2,) or not interval[0] <= interval[1]:
                raise ValueError(f"guf_interval must be [low, high], got {guf_interval!r}")
        else:
            k = stats.norm.ppf((1 + p) / 2) if guf_coverage_factor is None else guf_coverage_factor
            if not k > 0:
                raise ValueError(f"guf_coverage_factor must be positive, got {k}")
            interval = estimate[0] + np.array([-1.0, 1.0]) * k * u[0]
        low, high = mcm.interval[0]
        rows = (
            _row(names[0], "interval low", interval[0], low, delta[0]),
            _row(names[0], "interval high", interval[1], high, delta[0]),
        )
        procedure = "JCGM 101:2008 §8"
    else:
        k_guf = (
            normal_ellipsoidal_coverage_factor(m, p)
            if guf_coverage_factor is None
            else float(guf_coverage_factor)
        )
        lam_guf = _largest_eigenvalue(covariance)
        rho = tolerance.eigenvalue
        kappa = tolerance.coverage_factor
        rho = numerical_tolerance(mcm.largest_eigenvalue, 2) if rho is None else rho
        kappa = numerical_tolerance(mcm.region_coverage_factor, 2) if kappa is None else kappa
        rows = (
            *(
                row
                for j in range(m)
                for row in (
                    _row(names[j], "estimate", estimate[j], mcm.estimate[j], delta[j]),
                    _row(
                        names[j],
                        "standard uncertainty",
                        u[j],
                        mcm.standard_uncertainty[j],
                        delta[j],
                    ),
                )
            ),
            _row("all", "largest eigenvalue", lam_guf, mcm.largest_eigenvalue, rho),
            _row("all", "coverage factor", k_guf, mcm.region_coverage_factor, kappa),
        )
        procedure = "JCGM 102:2011 §8"
    failed = [row for row in rows if not row.passed]
    if failed:
        named = ", ".join(f"{row.name} {row.quantity} ({100 * row.ratio:.0f} %)" for row in failed)
        message = f"GUF not validated at p = {p:g}: {named} outside tolerance"
    else:
        worst = max(rows, key=lambda row: row.ratio)
        message = (
            f"GUF validated at p = {p:g}: all {len(rows)} differences within tolerance "
            f"(largest {100 * worst.ratio:.0f} %, {worst.name} {worst.quantity})"
        )
    return ValidationReport(rows=rows, p=p, procedure=procedure, message=message)


def validate_results(guf_result, mcm_result: MCMResult, *, tolerance=None, digits: int = 2):
    """Validate a :class:`~mtmetrology.uncertainty.guf.GUFResult` by a Monte Carlo result.

    Parameters
    ----------
    guf_result : GUFResult
    mcm_result : MCMResult
        Same model, same p, same output names.
    tolerance : float, (m,) array or NumericalTolerance, optional
        δ (and ρ, κ_p); by default the tolerance of an adaptive run, else δ from
        ``digits`` significant digits of the Monte Carlo u(y) (JCGM 101:2008, 7.9.2).
    digits : int
        n_dig for the default δ.

    Returns
    -------
    ValidationReport
        One output: the GUF interval y ± k u (k from t_ν_eff) against the probabilistically
        symmetric Monte Carlo interval (JCGM 101:2008, 8.2). m > 1: estimates,
        standard uncertainties, λ_max and the hyper-ellipsoid k_p (JCGM 102:2011, 8).

    Raises
    ------
    InputError
        If the two results differ in p or in the output names.

    References
    ----------
    JCGM 101:2008, clause 8, and JCGM 102:2011, clause 8 (full entries under
    :func:`validate_guf`).

    Examples
    --------
    JCGM 101:2008, 9.2.3 (Table 3): Y = X₁ + X₂ + X₃ + X₄ with rectangular inputs of
    u = 1. The GUF interval [−3.92, 3.92] against the Monte Carlo [−3.88, 3.88]: with two
    significant digits of u(y) = 2.0, δ = 0.05 and the GUF is validated.

    >>> import numpy as np
    >>> from mtmetrology.uncertainty import InputQuantity, InputSet, Rectangular, guf
    >>> from mtmetrology.uncertainty.mcm import monte_carlo
    >>> a = np.sqrt(3.0)
    >>> inputs = InputSet([InputQuantity(f"X{i}", Rectangular(-a, a)) for i in range(1, 5)])
    >>> def model(x):
    ...     return x.sum(axis=-1)
    >>> g = guf(model, inputs, output_names=["Y"])
    >>> r = monte_carlo(model, inputs, trials=10**6, seed=9, output_names=["Y"])
    >>> print(f"{g.output().interval[1]:.2f} {r.output().interval[1]:.2f}")
    3.92 3.88
    >>> validate_results(g, r).passed
    True
    """
    if abs(guf_result.p - mcm_result.p) > 1e-12 or tuple(guf_result.names) != mcm_result.names:
        raise InputError(
            f"the GUF and Monte Carlo results differ in p ({guf_result.p}, {mcm_result.p}) "
            f"or output names ({list(guf_result.names)}, {list(mcm_result.names)})"
        )
    if tolerance is None:
        tolerance = mcm_result.tolerance or NumericalTolerance(
            numerical_tolerance(mcm_result.standard_uncertainty, digits)
        )
    scalar = mcm_result.m == 1
    return validate_guf(
        guf_result.estimate,
        guf_result.covariance,
        mcm_result,
        tolerance=tolerance,
        p=guf_result.p,
        guf_coverage_factor=None if scalar else guf_result.region_coverage_factor,
        guf_interval=guf_result.interval[0] if scalar else None,
        names=list(guf_result.names),
    )
