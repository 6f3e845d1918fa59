"""ISO 14253-1:2017 decision rules: conformance, non-conformance or undecided.

One implementation for every command that takes ``--tolerance``: a :class:`Tolerance`
(nominal value and one or two limit deviations) and :func:`decide`, which compares a
measurement result ``y`` with expanded uncertainty ``U`` (symmetric, or the two sides of an
asymmetric coverage interval) against the specification zone reduced or extended by guard
bands.

References
----------
ISO 14253-1:2017. *Geometrical product specifications (GPS) — Inspection by measurement of
workpieces and measuring equipment — Part 1: Decision rules for verifying conformity or
nonconformity with specifications*, clauses 5 and 6.

JCGM 106:2012. *Evaluation of measurement data — The role of measurement uncertainty in
conformity assessment*, clause 8 (acceptance intervals and guard bands).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

from mtmetrology.errors import InputError

__all__ = ["ConformityDecision", "Decision", "Tolerance", "decide"]


class Decision(StrEnum):
    """The three outcomes of an ISO 14253-1:2017 decision."""

    CONFORMANCE = "conformance"
    NON_CONFORMANCE = "non-conformance"
    UNDECIDED = "undecided"


def _finite(value: float, name: str) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected a number, got {value!r}") from None
    if not math.isfinite(number):
        raise InputError(f"{name}: expected a finite number, got {value!r}")
    return number


@dataclass(frozen=True)
class Tolerance:
    """A one- or two-sided specification: nominal value and signed limit deviations.

    Parameters
    ----------
    nominal : float
        Nominal value, in the unit of the result it is compared with.
    lower_deviation, upper_deviation : float or None
        Signed deviations of the lower and upper specification limits from the nominal
        (``25, -0.010, +0.015`` gives the zone 24.990 ... 25.015). ``None`` leaves that side
        open (a one-sided tolerance such as flatness ``0, None, 0.010``).

    Raises
    ------
    InputError
        Both sides open, a non-finite number, or a lower limit above the upper one.

    Examples
    --------
    >>> t = Tolerance.parse("25,-0.01,0.015")
    >>> t.lower_limit, t.upper_limit
    (24.99, 25.015)
    >>> Tolerance.parse("0,,0.01").lower_limit
    -inf
    """

    nominal: float
    lower_deviation: float | None
    upper_deviation: float | None

    def __post_init__(self) -> None:
        object.__setattr__(self, "nominal", _finite(self.nominal, "tolerance nominal"))
        for side in ("lower_deviation", "upper_deviation"):
            value = getattr(self, side)
            if value is not None:
                object.__setattr__(self, side, _finite(value, f"tolerance {side}"))
        if self.lower_deviation is None and self.upper_deviation is None:
            raise InputError("tolerance: give a lower or an upper limit deviation (or both)")
        if self.lower_limit > self.upper_limit:
            raise InputError(
                f"tolerance: the lower limit {self.lower_limit:g} is above the upper limit "
                f"{self.upper_limit:g}; give NOMINAL,LOWER,UPPER with LOWER <= UPPER"
            )

    @classmethod
    def parse(cls, text: str, *, parameter: str = "--tolerance") -> Tolerance:
        """Read ``NOMINAL,LOWER,UPPER`` (deviations from nominal; leave one side empty).

        Raises
        ------
        InputError
            Not three comma-separated fields, or a field that is not a finite number; the
            message names ``parameter``.
        """
        fields = [f.strip() for f in str(text).split(",")]
        if len(fields) != 3 or not fields[0]:
            raise InputError(
                f"{parameter}: expected NOMINAL,LOWER,UPPER (deviations; one may be empty), "
                f"got {text!r}"
            )
        nominal = _finite(fields[0], f"{parameter} NOMINAL")
        lower = _finite(fields[1], f"{parameter} LOWER") if fields[1] else None
        upper = _finite(fields[2], f"{parameter} UPPER") if fields[2] else None
        return cls(nominal, lower, upper)

    @property
    def lower_limit(self) -> float:
        """Lower specification limit (LSL); ``-inf`` when the tolerance is upper-only."""
        if self.lower_deviation is None:
            return -math.inf
        return self.nominal + self.lower_deviation

    @property
    def upper_limit(self) -> float:
        """Upper specification limit (USL); ``+inf`` when the tolerance is lower-only."""
        if self.upper_deviation is None:
            return math.inf
        return self.nominal + self.upper_deviation

    def to_dict(self) -> dict:
        """JSON form: nominal, deviations and limits, ``null`` for an open side."""
        return {
            "nominal": self.nominal,
            "lower_deviation": self.lower_deviation,
            "upper_deviation": self.upper_deviation,
            "lower_limit": _json_limit(self.lower_limit),
            "upper_limit": _json_limit(self.upper_limit),
        }


def _json_limit(x: float) -> float | None:
    return x if math.isfinite(x) else None


@dataclass(frozen=True)
class ConformityDecision:
    """The outcome of :func:`decide` with the zones it was taken on.

    Attributes
    ----------
    decision : Decision
        Conformance, non-conformance or undecided.
    value : float
        The measurement result y.
    uncertainty_below, uncertainty_above : float
        Expanded uncertainty below and above y (equal for a symmetric ``U``).
    guard_band_factor : float
        h: guard bands are h·U wide (1 for the ISO 14253-1:2017 default rule).
    tolerance : Tolerance
        The specification.
    acceptance_zone : tuple of float
        [LSL + h·U_below, USL − h·U_above]: conformance is proven inside (closed). Empty
        (low > high) when the uncertainty is too large to prove conformance.
    rejection_limits : tuple of float
        (LSL − h·U_above, USL + h·U_below): non-conformance is proven strictly outside.
    unit : str or None
        Unit of the value, uncertainty and tolerance, for the report.
    """

    decision: Decision
    value: float
    uncertainty_below: float
    uncertainty_above: float
    guard_band_factor: float
    tolerance: Tolerance
    acceptance_zone: tuple[float, float]
    rejection_limits: tuple[float, float]
    unit: str | None = None

    @property
    def conforms(self) -> bool:
        """True only when conformance is proven."""
        return self.decision is Decision.CONFORMANCE

    def to_dict(self) -> dict:
        """JSON form (``null`` for an open side of a one-sided tolerance)."""
        return {
            "kind": "conformity-decision",
            "version": 1,
            "rule": "ISO 14253-1:2017",
            "decision": self.decision.value,
            "value": self.value,
            "unit": self.unit,
            "uncertainty_below": self.uncertainty_below,
            "uncertainty_above": self.uncertainty_above,
            "guard_band_factor": self.guard_band_factor,
            "tolerance": self.tolerance.to_dict(),
            "acceptance_zone": [_json_limit(x) for x in self.acceptance_zone],
            "rejection_limits": [_json_limit(x) for x in self.rejection_limits],
        }


def decide(
    value: float,
    expanded_uncertainty: float | tuple[float, float],
    tolerance: Tolerance,
    *,
    guard_band_factor: float = 1.0,
    unit: str | None = None,
) -> ConformityDecision:
    """Decide conformance of a measurement result against a tolerance (ISO 14253-1:2017).

    Parameters
    ----------
    value : float
        Measurement result y, in the unit of the tolerance.
    expanded_uncertainty : float or (float, float)
        U (same unit), or ``(U_below, U_above)`` for an asymmetric coverage interval
        [y − U_below, y + U_above] (e.g. a Monte Carlo shortest interval).
    tolerance : Tolerance
        The specification zone [LSL, USL] (one side may be open).
    guard_band_factor : float, default 1
        h ≥ 0: guard bands h·U. h = 1 is the ISO 14253-1:2017 default; h = 0 is simple
        acceptance (shared risk, by agreement only); 0 < h < 1 are the reduced guard bands
        of JCGM 106:2012, 8.3.
    unit : str, optional
        Unit recorded in the result, for reports.

    Returns
    -------
    ConformityDecision

    Raises
    ------
    InputError
        A non-finite value, a negative or non-finite uncertainty or guard-band factor.

    Notes
    -----
    With g_below = h·U_below and g_above = h·U_above (ISO 14253-1:2017, 5.2 and 5.3;
    JCGM 106:2012, 8.3.2)::

        conformance       LSL + g_below <= y <= USL − g_above   (interval inside the zone)
        non-conformance   y < LSL − g_above  or  y > USL + g_below   (interval outside)
        undecided         otherwise (the interval contains a specification limit)

    The specification limits belong to the specification zone, so a result whose
    interval just touches a limit from inside conforms, and one that touches it from
    outside is undecided. When U is larger than half the tolerance the acceptance zone is
    empty and conformance cannot be proven.

    Examples
    --------
    >>> t = Tolerance(10.0, -0.25, 0.5)
    >>> decide(10.375, 0.125, t).decision.value
    'conformance'
    >>> decide(10.5, 0.125, t).decision.value
    'undecided'
    >>> decide(10.75, 0.125, t).decision.value
    'non-conformance'
    """
    y = _finite(value, "value")
    if isinstance(expanded_uncertainty, tuple | list):
        if len(expanded_uncertainty) != 2:
            raise InputError("expanded_uncertainty: give U or (U_below, U_above)")
        below, above = expanded_uncertainty
    else:
        below = above = expanded_uncertainty
    below = _finite(below, "expanded_uncertainty")
    above = _finite(above, "expanded_uncertainty")
    h = _finite(guard_band_factor, "guard_band_factor")
    if below < 0 or above < 0:
        raise InputError("expanded_uncertainty: must be >= 0")
    if h < 0:
        raise InputError("guard_band_factor: must be >= 0")
    lsl, usl = tolerance.lower_limit, tolerance.upper_limit
    acceptance = (lsl + h * below, usl - h * above)
    rejection = (lsl - h * above, usl + h * below)
    if acceptance[0] <= y <= acceptance[1]:
        decision = Decision.CONFORMANCE
    elif y < rejection[0] or y > rejection[1]:
        decision = Decision.NON_CONFORMANCE
    else:
        decision = Decision.UNDECIDED
    return ConformityDecision(decision, y, below, above, h, tolerance, acceptance, rejection, unit)
