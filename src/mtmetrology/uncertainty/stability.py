"""Numerical tolerances and the stability tests of the adaptive Monte Carlo procedure.

JCGM 101:2008, 7.9 (and JCGM 102:2011, 7.8 for m outputs): the procedure runs sequences
of M trials until, for each quantity of interest — the estimate y_j, the standard
uncertainty u(y_j), the ends of the coverage interval and, for m > 1, the largest
eigenvalue λ_max of the correlation matrix and the coverage factor k_p — twice the
standard deviation of the average of its h per-sequence values is within the numerical
tolerance δ derived from the significant digits of u(y) (7.9.2).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from mtmetrology.uncertainty.regions import coverage_intervals, scatter
from mtmetrology.uncertainty.sample_statistics import correlation_matrix, joint_coverage_factors

__all__ = [
    "ConvergenceCheck",
    "NumericalTolerance",
    "check_tolerance",
    "numerical_tolerance",
    "sequence_statistics",
    "stability_checks",
]


def numerical_tolerance(value, digits: int = 2):
    """Numerical tolerance δ = ½·10^l of a value stated to ``digits`` significant digits.

    Parameters
    ----------
    value : float or array
        The quantity whose digits are to be meaningful, usually u(y); its magnitude is used.
    digits : int
        Number of significant decimal digits n_dig (1 or 2 in practice).

    Returns
    -------
    float or array
        δ, same shape as ``value``; 0 where ``value`` is 0.

    Raises
    ------
    ValueError
        If digits < 1 or value is not finite.

    Notes
    -----
    JCGM 101:2008, 7.9.2: write the value as c × 10^l with c an n_dig-digit integer; then
    δ = ½ × 10^l. For u = 0.0123 and n_dig = 2, c = 12, l = −3 and δ = 0.0005.

    Examples
    --------
    >>> float(numerical_tolerance(0.0123, 2))
    0.0005
    """
    if int(digits) != digits or digits < 1:
        raise ValueError(f"digits must be a positive integer, got {digits}")
    magnitude = np.abs(np.asarray(value, dtype=float))
    if not np.all(np.isfinite(magnitude)):
        raise ValueError(f"cannot derive a tolerance from a non-finite value {value!r}")
    with np.errstate(divide="ignore"):
        exponent = np.floor(np.log10(np.where(magnitude > 0, magnitude, 1.0))) - int(digits) + 1
    tolerance = np.where(magnitude > 0, 0.5 * 10.0**exponent, 0.0)
    return float(tolerance) if tolerance.ndim == 0 else tolerance


@dataclass(frozen=True, eq=False)
class NumericalTolerance:
    """Numerical tolerances (JCGM 101:2008, 7.9.2) of the adaptive procedure and of GUF
    validation (a specification is :class:`~mtmetrology.uncertainty.conformity.Tolerance`).

    Attributes
    ----------
    output : float or (m,) array
        δ for the estimates, standard uncertainties and interval ends (output units).
    eigenvalue : float, optional
        ρ for the largest eigenvalue of the correlation matrix (dimensionless).
    coverage_factor : float, optional
        κ_p for the hyper-ellipsoidal coverage factor k_p (dimensionless).

    Notes
    -----
    Sepahi Boroujeni (2021), Ch. 7 (Tables 7-1, 7-2): δ = 0.05 µm, ρ = κ_p = 0.05. A field
    left as None is derived from the significant digits (JCGM 101:2008, 7.9.2).
    """

    output: Any
    eigenvalue: float | None = None
    coverage_factor: float | None = None

    def for_outputs(self, m: int) -> np.ndarray:
        """δ as an (m,) array; raises if a per-output array has another length."""
        output = np.asarray(self.output, dtype=float)
        if output.ndim == 1 and output.shape != (m,):
            raise ValueError(f"tolerance has {output.size} entries for {m} model outputs")
        return np.broadcast_to(output, (m,)).copy()


def check_tolerance(tolerance) -> NumericalTolerance | None:
    """A user's tolerance (None, a number, a 1-D array or a NumericalTolerance), checked
    and wrapped.

    Raises
    ------
    ValueError
        If a tolerance is not positive and finite, or the array is not one-dimensional.
    """
    if tolerance is None:
        return None
    if not isinstance(tolerance, NumericalTolerance):
        tolerance = NumericalTolerance(tolerance)
    output = np.asarray(tolerance.output, dtype=float)
    if output.ndim > 1 or not np.all(np.isfinite(output)) or np.any(output <= 0):
        raise ValueError(
            f"tolerance must be a positive number or a 1-D array of them, got {tolerance.output!r}"
        )
    for name in ("eigenvalue", "coverage_factor"):
        value = getattr(tolerance, name)
        if value is not None and not (np.isfinite(value) and value > 0):
            raise ValueError(f"tolerance.{name} must be a positive number, got {value!r}")
    return tolerance


@dataclass(frozen=True)
class ConvergenceCheck:
    """One stability test of the adaptive procedure.

    ``spread`` is 2·s/√h (criterion "jcgm") or s (criterion "strict"), where s is the
    standard deviation of the h per-sequence values of ``quantity`` for ``output``
    (None for the joint quantities λ_max and k_p).
    """

    quantity: str
    output: int | None
    spread: float
    tolerance: float

    @property
    def passed(self) -> bool:
        return bool(self.spread <= self.tolerance)


def sequence_statistics(values: np.ndarray, p: float) -> np.ndarray:
    """The quantities the adaptive procedure tests, for one sequence of model values.

    Parameters
    ----------
    values : (M, m) ndarray
        The model values of one sequence.
    p : float
        Coverage probability.

    Returns
    -------
    (4m,) or (4m + 2,) ndarray
        [y (m), u(y) (m), interval low (m), interval high (m)] and, for m > 1,
        [λ_max, k_p] (JCGM 101:2008, 7.9.4; JCGM 102:2011, 7.8).
    """
    m = values.shape[1]
    estimate = values.mean(axis=0)
    deviations = values - estimate
    covariance = scatter(deviations) / (values.shape[0] - 1)
    symmetric, _ = coverage_intervals(values, p)  # (m, 2)
    parts = [estimate, np.sqrt(np.diag(covariance)), symmetric[:, 0], symmetric[:, 1]]
    if m > 1:
        largest = np.linalg.eigvalsh(correlation_matrix(covariance))[-1]
        k_p, _ = joint_coverage_factors(values, estimate, covariance, p)
        parts.append(np.array([largest, k_p]))
    return np.concatenate(parts)


_QUANTITIES = ("estimate", "standard uncertainty", "interval low", "interval high")


def stability_checks(per_sequence, moments, m, tolerance, digits, criterion):
    """The stopping tests of the adaptive procedure after h sequences.

    Parameters
    ----------
    per_sequence : sequence of ndarray
        The :func:`sequence_statistics` of each of the h sequences.
    moments : Moments
        Of all h·M values; u(y) of all values gives δ (JCGM 101:2008, 7.9.4 h).
    m : int
        Number of outputs.
    tolerance : NumericalTolerance or None
        Explicit tolerances; None derives δ, ρ and κ_p from ``digits``.
    digits : int
        Significant digits n_dig (JCGM 101:2008, 7.9.2).
    criterion : {"jcgm", "strict"}
        "jcgm": the spread is 2·s/√h, twice the standard deviation of the average of the
        h values (JCGM 101:2008, 7.9.4; JCGM 102:2011, 7.8); "strict": s itself
        (Sepahi Boroujeni 2021, Ch. 5, eq. 5-12).

    Returns
    -------
    checks : list of ConvergenceCheck
        One per output for y, u(y) and the two interval ends, then λ_max and k_p for m > 1.
    applied : NumericalTolerance
        The tolerances as applied.
    """
    table = np.asarray(per_sequence)  # (h, 4m [+ 2])
    h = table.shape[0]
    spread = table.std(axis=0, ddof=1)
    if criterion == "jcgm":
        spread = 2.0 * spread / np.sqrt(h)  # twice the standard deviation of the average
    u = np.sqrt(np.diag(moments.covariance))  # u(y) from all h·M values (7.9.4 h)
    if tolerance is None:
        delta, rho, kappa = numerical_tolerance(u, digits), None, None
    else:
        delta, rho, kappa = (
            tolerance.for_outputs(m),
            tolerance.eigenvalue,
            tolerance.coverage_factor,
        )
    averages = table.mean(axis=0)
    if m > 1:
        rho = numerical_tolerance(averages[4 * m], digits) if rho is None else rho
        kappa = numerical_tolerance(averages[4 * m + 1], digits) if kappa is None else kappa
    checks = [
        ConvergenceCheck(name, j, float(spread[block * m + j]), float(delta[j]))
        for block, name in enumerate(_QUANTITIES)
        for j in range(m)
    ]
    if m > 1:
        checks.append(ConvergenceCheck("largest eigenvalue", None, float(spread[4 * m]), rho))
        checks.append(ConvergenceCheck("coverage factor", None, float(spread[4 * m + 1]), kappa))
    return checks, NumericalTolerance(delta, rho, kappa)
