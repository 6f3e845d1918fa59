"""ISO 15530-3 budgets: the uncertainty of a task measured like a calibrated workpiece.

A workpiece (or a similar one) with a calibrated value x_cal, u_cal is measured n times on
the machine under production conditions; the mean ȳ, its bias b = ȳ − x_cal and the
spread u_p of the repeats give the task uncertainty of the same measurement on other parts
(ISO 15530-3, clause 7).  Three combination rules are in use and are named here
(:class:`Policy`), because the printed editions and the literature differ exactly on b:

=========  ===================================================  ==========================
policy     expanded uncertainty                                 reported result
=========  ===================================================  ==========================
2004       U = k·√(u_cal² + u_p² + u_w² + u_probe²) + |b|       ȳ (b not corrected)
2011       U = k·√(u_cal² + u_p² + u_b² + u_w² + u_probe²)      ȳ − b (b corrected; u_b is
                                                                the uncertainty of b beyond
                                                                u_cal and u_p, e.g. thermal)
paper003   U = k·√(u_b² + u_p² + u_cal² + u_w² + u_probe²),     ȳ (b not corrected)
           u_b = |b|
=========  ===================================================  ==========================

``paper003`` is Mutilba et al.'s Eq. 1 read as Table 1 computes it (u_b = |b| inside the
root); Eq. 1 is printed as √(u_p² + u_cal² + b), b unsquared — a typo that Table 1 does
not follow (row "X position Ø108": 7.5 µm by the printed form, 8.0 µm in the table).

u_p (Eq. 3) is the sample standard deviation (n − 1) of the repeats, or, as ISO 15530-3
is used in practice, the largest sample standard deviation over several series of at
least 10 cycles each, 20 repeats at least in all (:class:`RepeatabilityMethod`).

The measurement model of one characteristic (ISO 15530-3, clause 7), all contributions
independent: y_part = y − b under ``2011`` (y under ``2004``/``paper003``, b then covered
by U), with standard uncertainty

    u = √(u_cal² + u_p² + u_b² + u_w² + u_probe²)     (u_b = 0 under 2004, |b| paper003)

where u_w, the variation between the parts and the reference workpiece, may be given or
evaluated from its inputs (:class:`~mtmetrology.budgets.workpiece.WorkpieceVariation`:
u_w = (t − 20 °C)·u_α·l and the temperature and form terms).

The standard's minimum, at least 20 repeats in series of at least 10 cycles, is enforced
under every policy and u_p method (a u_p from 2 repeats has one degree of freedom, from 19
it is still not the standard's); fewer repeats are accepted only when asked
(``allow_few_repeats``), and the deviation is then recorded in the result
(:attr:`ISO15530Budget.deviations`). The repeats, the production part's readings and the
calibrated value must be in the same unit (mm): magnitudes that differ by more than a
factor √10³ (half of the three decades of a µm/mm or mm/m slip, on a log scale; magnitudes
below 0.1 mm count as 0.1 mm, for form and position near zero) are refused, naming both.

A production part's readings (``part``) give its result, the same U and the ISO 14253-1
decision against the tolerance (:class:`PartResult`).

The probing system's systematic error enters in quadrature (u_probe) only when it is
above the threshold of the machine class (1 µm small, 3 µm large machine; Mutilba et al.,
Section 3, step 6); below it the probe term is negligible and stated as such.

References
----------
ISO 15530-3:2004 and ISO 15530-3:2011. *Geometrical product specifications (GPS) —
Coordinate measuring machines (CMM): Technique for determining the uncertainty of
measurement — Part 3: Use of calibrated workpieces or measurement standards*, clause 7.

Mutilba, U. et al. *On-machine measurement uncertainty without a calibrated workpiece:
a VDI/VDE 2617-11 budget with a volumetric error map* (seed 003), Eqs. 1–3 and Table 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from mtmetrology.budgets.choices import Policy, RepeatabilityMethod
from mtmetrology.budgets.repeats import repeat_shortfall, repeatability
from mtmetrology.budgets.workpiece import WorkpieceVariation, checked_number
from mtmetrology.errors import InputError
from mtmetrology.uncertainty.conformity import ConformityDecision, Tolerance, decide
from mtmetrology.uncertainty.coverage import BIAS_ADDED
from mtmetrology.uncertainty.outputs import Output
from mtmetrology.units import from_internal, to_internal

__all__ = [
    "BUDGET_KIND",
    "ISO_POLICIES",
    "PROBE_THRESHOLD",
    "ISO15530Budget",
    "PartResult",
    "budget_output",
    "check_same_unit",
    "combine",
    "iso15530_3_budget",
    "probe_contribution",
    "repeat_shortfall",
    "repeatability",
]

BUDGET_KIND = "iso15530-3-budget"
_VERSION = 1

#: Probe systematic error below which the probe term is negligible, by machine class (mm).
PROBE_THRESHOLD = {"small": to_internal(1.0, "µm"), "large": to_internal(3.0, "µm")}

#: The policies of the standard's editions, which require its minimum of repeats.
ISO_POLICIES = (Policy.ISO_2004, Policy.ISO_2011)
#: Largest factor between the magnitudes of values in the same unit (module notes).
UNIT_RATIO_LIMIT = 10.0**1.5
#: Magnitudes below this (mm) count as it in the unit check: form, position near zero.
_MAGNITUDE_FLOOR = 0.1


def _nonnegative(value: float, name: str) -> float:
    x = checked_number(value, name)
    if x < 0:
        raise InputError(f"{name}: must be a finite number >= 0, got {value!r}")
    return x


def check_same_unit(value: float, calibrated: float, what: str) -> None:
    """Refuse values that cannot be in the same unit as the calibrated value (mm).

    A bias of an ISO 15530-3 budget is a small systematic error: a repeats' mean or a
    part's reading whose magnitude differs from x_cal's by more than
    :data:`UNIT_RATIO_LIMIT` (magnitudes below 0.1 mm counted as 0.1 mm) is a value in
    another unit (µm, m), never a bias (issue 30: runs in µm against x_cal in mm gave
    b = 4.996e7 µm).

    Raises
    ------
    InputError
        Naming ``what`` and ``--calibrated`` with both values.
    """
    a = max(abs(value), _MAGNITUDE_FLOOR)
    c = max(abs(calibrated), _MAGNITUDE_FLOOR)
    ratio = max(a, c) / min(a, c)
    if ratio > UNIT_RATIO_LIMIT:
        raise InputError(
            f"{what} ({value:g}) and --calibrated ({calibrated:g}) differ by a factor "
            f"{ratio:.3g}: both must be in mm"
        )


def probe_contribution(probe_error: float, machine_class: str = "small") -> float:
    """The probe's systematic error as it enters the budget: itself above the threshold.

    Parameters
    ----------
    probe_error : float
        Systematic error of the probing system (mm, ≥ 0), e.g. from the ring calibration.
    machine_class : {"small", "large"}
        Threshold 1 µm (small machine) or 3 µm (large machine).

    Returns
    -------
    float
        ``probe_error`` when it is above the threshold, else 0 (negligible).
    """
    e = _nonnegative(probe_error, "probe error")
    if machine_class not in PROBE_THRESHOLD:
        raise InputError(f"machine class: 'small' or 'large', got {machine_class!r}")
    return e if e > PROBE_THRESHOLD[machine_class] else 0.0


def combine(
    policy: Policy | str,
    *,
    b: float,
    u_p: float,
    u_cal: float,
    u_w: float = 0.0,
    u_b: float = 0.0,
    u_probe: float = 0.0,
    k: float = 2.0,
) -> tuple[float, float]:
    """Combined standard and expanded uncertainty of one characteristic.

    u = √(u_cal² + u_p² + u_b² + u_w² + u_probe²) with u_b the policy's (0 under ``2004``,
    |b| under ``paper003``); U = k·u, plus |b| under ``2004`` (ISO 15530-3:2004 and :2011,
    clause 7; Mutilba et al., Eqs. 1–2).

    Parameters
    ----------
    policy : Policy
        ``2004``, ``2011`` or ``paper003`` (module notes).
    b : float
        Bias ȳ − x_cal (signed).
    u_p, u_cal, u_w, u_probe : float
        Standard uncertainties (≥ 0): repeatability, calibration of the reference, material
        and manufacturing variation, probe systematic term (already thresholded).
    u_b : float
        Uncertainty of the bias estimate (``2011`` only; ``paper003`` uses |b|).
    k : float
        Coverage factor.

    Returns
    -------
    (u, U) : tuple of float
        u is the root-sum-square inside the root; U = k·u (+ |b| for ``2004``).

    Examples
    --------
    Row "X position (Ø108 mm)" of Mutilba et al., Table 1 (µm):

    >>> round(combine("paper003", b=2.0, u_p=3.3, u_cal=1.0)[1], 1)
    8.0
    >>> round(combine("2004", b=2.0, u_p=3.3, u_cal=1.0)[1], 1)
    8.9
    """
    policy = Policy(policy)
    for name, v in (("u_p", u_p), ("u_cal", u_cal), ("u_w", u_w), ("u_b", u_b)):
        _nonnegative(v, name)
    _nonnegative(u_probe, "u_probe")
    if not (math.isfinite(k) and k > 0):
        raise InputError(f"k: coverage factor must be > 0, got {k!r}")
    terms = [u_p, u_cal, u_w, u_probe]
    if policy is Policy.ISO_2011:
        terms.append(u_b)
    elif policy is Policy.PAPER_003:
        terms.append(abs(b))
    u = math.sqrt(sum(t * t for t in terms))
    expanded = k * u + (abs(b) if policy is Policy.ISO_2004 else 0.0)
    return u, expanded


def budget_output(name: str, value: float, u: float, expanded: float, k: float) -> Output:
    """A budget's result in the project's uncertainty-result vocabulary.

    ``p`` is the probability of ±k·u for a normal distribution (0.9545 for k = 2), the
    usual reading of a budget's coverage factor (JCGM 100:2008, 6.3.3); the interval is
    value ± U, and the stated k is U/u (larger than the coverage factor when |b| is added
    outside the root).
    """
    return Output(
        name=name,
        value=float(value),
        unit="mm",
        u=float(u),
        U=float(expanded),
        k=float(expanded / u) if u > 0 else None,
        p=math.erf(k / math.sqrt(2.0)),
        interval=(float(value - expanded), float(value + expanded)),
    )


def _um(x: float | None) -> float | None:
    return None if x is None else float(from_internal(x, "µm"))


def _decision_from_dict(d: dict | None) -> ConformityDecision | None:
    """The decision of a :meth:`ConformityDecision.to_dict`, taken again from its tolerance."""
    if d is None:
        return None
    t = d["tolerance"]
    return decide(
        d["value"],
        (d["uncertainty_below"], d["uncertainty_above"]),
        Tolerance(t["nominal"], t["lower_deviation"], t["upper_deviation"]),
        guard_band_factor=d["guard_band_factor"],
        unit=d.get("unit"),
    )


@dataclass(frozen=True)
class PartResult:
    """A production part measured like the calibrated workpiece: its result and decision.

    Attributes
    ----------
    name : str
    n : int
        Readings of the part (averaged).
    mean : float
        y, the mean of the readings (mm).
    bias_corrected : bool
        Whether b was subtracted (policy ``2011``; ``2004`` and ``paper003`` leave b in
        the result and cover it by U).
    result : float
        y − b under ``2011``, else y (mm).
    U : float
        The budget's expanded uncertainty (mm): the task uncertainty of one measurement of
        a part like the reference, so a conservative bound for a mean of readings.
    decision : ConformityDecision or None
        ISO 14253-1 decision of ``result`` ± U against the tolerance, if one was given.
    """

    name: str
    n: int
    mean: float
    bias_corrected: bool
    result: float
    U: float
    decision: ConformityDecision | None = None

    def to_dict(self, u: float, k: float) -> dict:
        """JSON form; ``u`` and ``k`` are the budget's (for the output record)."""
        return {
            "name": self.name,
            "n": self.n,
            "mean": self.mean,
            "bias_corrected": self.bias_corrected,
            "result": self.result,
            "U": self.U,
            "um": {"U": _um(self.U)},
            "output": budget_output(self.name, self.result, u, self.U, k).to_dict(),
            "decision": None if self.decision is None else self.decision.to_dict(),
        }

    @classmethod
    def from_dict(cls, doc: dict) -> PartResult:
        """Read :meth:`to_dict`'s form back."""
        return cls(
            name=str(doc["name"]),
            n=int(doc["n"]),
            mean=float(doc["mean"]),
            bias_corrected=bool(doc["bias_corrected"]),
            result=float(doc["result"]),
            U=float(doc["U"]),
            decision=_decision_from_dict(doc.get("decision")),
        )


@dataclass(frozen=True)
class ISO15530Budget:
    """An ISO 15530-3 task-uncertainty budget of one characteristic (lengths in mm).

    Attributes
    ----------
    policy : Policy
    repeatability_method : RepeatabilityMethod
    n : int
        Repeated cycles used.
    mean : float
        ȳ, mean of the repeats.
    calibrated : float
        x_cal, calibrated value of the reference workpiece.
    b : float
        ȳ − x_cal.
    u_p, u_cal, u_w, u_b, u_probe : float
        Contributions (standard uncertainties); ``u_b`` is the bias term as the policy uses
        it (|b| for ``paper003``, the given u_b for ``2011``, 0 for ``2004``); ``u_probe``
        is 0 when the probe error is below its threshold.
    probe_error : float
        The probe systematic error given (before the threshold).
    machine_class : str
    k : float
    u : float
        Root-sum-square of the contributions inside the root.
    U : float
        Expanded uncertainty by the policy's rule.
    result : float
        The reported measurement result: ȳ, or ȳ − b under ``2011``.
    decision : ConformityDecision or None
        ISO 14253-1 decision of the reference workpiece's ``result`` ± U against the
        tolerance, when a tolerance and no part were given.
    name : str
        Name of the characteristic.
    provenance : dict
    deviations : tuple of str
        Deviations from ISO 15530-3 the user allowed (too few repeats), in words.
    part : PartResult or None
        The production part's result and decision.
    workpiece : WorkpieceVariation or None
        The inputs u_w was evaluated from (None when u_w was given).
    """

    policy: Policy
    repeatability_method: RepeatabilityMethod
    n: int
    mean: float
    calibrated: float
    b: float
    u_p: float
    u_cal: float
    u_w: float
    u_b: float
    u_probe: float
    probe_error: float
    machine_class: str
    k: float
    u: float
    U: float
    result: float
    decision: ConformityDecision | None = None
    name: str = "characteristic"
    provenance: dict = field(default_factory=dict)
    deviations: tuple[str, ...] = ()
    part: PartResult | None = None
    workpiece: WorkpieceVariation | None = None

    def to_dict(self) -> dict:
        """JSON form: values in mm, contributions and uncertainties also in µm."""
        return {
            "kind": BUDGET_KIND,
            "version": _VERSION,
            "name": self.name,
            "policy": self.policy.value,
            "repeatability_method": self.repeatability_method.value,
            "n": self.n,
            "unit": "mm",
            "mean": self.mean,
            "calibrated": self.calibrated,
            "b": self.b,
            "result": self.result,
            "contributions": {
                "u_p": self.u_p,
                "u_cal": self.u_cal,
                "u_w": self.u_w,
                "u_b": self.u_b,
                "u_probe": self.u_probe,
            },
            "probe_error": self.probe_error,
            "machine_class": self.machine_class,
            "k": self.k,
            "u": self.u,
            "U": self.U,
            "U_rule": BIAS_ADDED if self.policy is Policy.ISO_2004 else "U = k·u",
            "um": {
                "b": _um(self.b),
                "u_p": _um(self.u_p),
                "u_cal": _um(self.u_cal),
                "u_w": _um(self.u_w),
                "u_b": _um(self.u_b),
                "u_probe": _um(self.u_probe),
                "u": _um(self.u),
                "U": _um(self.U),
            },
            "outputs": [budget_output(self.name, self.result, self.u, self.U, self.k).to_dict()],
            "decision": None if self.decision is None else self.decision.to_dict(),
            "deviations": list(self.deviations),
            "part": None if self.part is None else self.part.to_dict(self.u, self.k),
            "workpiece": None if self.workpiece is None else self.workpiece.to_dict(),
            "provenance": dict(self.provenance),
        }

    @classmethod
    def from_dict(cls, doc: dict) -> ISO15530Budget:
        """Read :meth:`to_dict`'s form back (the decision is taken again from its tolerance)."""
        if doc.get("kind") != BUDGET_KIND:
            raise InputError(f"budget: kind must be {BUDGET_KIND!r}, got {doc.get('kind')!r}")
        if doc.get("version") != _VERSION:
            raise InputError(f"budget: version {doc.get('version')!r} is not {_VERSION}")
        c = doc["contributions"]
        part, workpiece = doc.get("part"), doc.get("workpiece")
        return cls(
            policy=Policy(doc["policy"]),
            repeatability_method=RepeatabilityMethod(doc["repeatability_method"]),
            n=int(doc["n"]),
            mean=float(doc["mean"]),
            calibrated=float(doc["calibrated"]),
            b=float(doc["b"]),
            u_p=float(c["u_p"]),
            u_cal=float(c["u_cal"]),
            u_w=float(c["u_w"]),
            u_b=float(c["u_b"]),
            u_probe=float(c["u_probe"]),
            probe_error=float(doc["probe_error"]),
            machine_class=str(doc["machine_class"]),
            k=float(doc["k"]),
            u=float(doc["u"]),
            U=float(doc["U"]),
            result=float(doc["result"]),
            decision=_decision_from_dict(doc.get("decision")),
            name=str(doc.get("name", "characteristic")),
            provenance=dict(doc.get("provenance", {})),
            deviations=tuple(str(d) for d in doc.get("deviations", [])),
            part=None if part is None else PartResult.from_dict(part),
            workpiece=None if workpiece is None else WorkpieceVariation.from_dict(workpiece),
        )


def iso15530_3_budget(
    values: np.ndarray,
    *,
    calibrated: float,
    u_cal: float,
    u_w: float = 0.0,
    u_b: float = 0.0,
    series: np.ndarray | None = None,
    policy: Policy | str = Policy.PAPER_003,
    repeatability_method: RepeatabilityMethod | str = RepeatabilityMethod.SAMPLE,
    probe_error: float = 0.0,
    machine_class: str = "small",
    k: float = 2.0,
    tolerance: Tolerance | None = None,
    name: str = "characteristic",
    provenance: dict | None = None,
    allow_few_repeats: bool = False,
    part: np.ndarray | None = None,
    part_name: str = "part",
    workpiece: WorkpieceVariation | None = None,
) -> ISO15530Budget:
    """ISO 15530-3 budget of one characteristic from repeated on-machine measurements.

    Parameters
    ----------
    values : (n,) array
        Results of the repeated cycles on the calibrated workpiece (mm).
    calibrated : float
        x_cal, the calibrated value of the same characteristic (mm).
    u_cal, u_w, u_b : float
        Standard uncertainties (mm, ≥ 0): calibration, workpiece variation, bias estimate
        (``2011`` only).
    series : (n,) array, optional
        Series labels (``max-over-series``, and the minimum of cycles per series).
    policy, repeatability_method
        See :class:`Policy` and :func:`repeatability`.
    probe_error, machine_class
        See :func:`probe_contribution`.
    k : float
        Coverage factor.
    tolerance : Tolerance, optional
        Specification; the ISO 14253-1 decision of the part's result ± U (of the reference
        workpiece's result without ``part``) is attached.
    allow_few_repeats : bool
        Proceed with fewer repeats than ISO 15530-3 requires (20 in series of at least 10,
        under every policy): the shortfall is recorded in ``deviations``.
    part : (m,) array, optional
        Readings of a production part measured like the workpiece (mm); their mean gives
        the part's result (:class:`PartResult`).
    part_name : str
        Name of the part in the result.
    workpiece : WorkpieceVariation, optional
        The inputs u_w is evaluated from (instead of ``u_w``); its length defaults to
        |x_cal|.

    Returns
    -------
    ISO15530Budget
        b = ȳ − x_cal; u and U by :func:`combine`; the part's result and decision.

    Raises
    ------
    InputError
        Negative or non-finite uncertainty, too few repeats for the policy (unless
        allowed), repeats or part readings not in the unit of x_cal, both ``u_w`` and
        ``workpiece``, unknown policy.
    """
    y = np.asarray(values, dtype=float).ravel()
    if not np.all(np.isfinite(y)):
        raise InputError("values: every repeated result must be a finite number")
    calibrated = checked_number(calibrated, "--calibrated")
    policy = Policy(policy)
    method = RepeatabilityMethod(repeatability_method)
    u_cal = _nonnegative(u_cal, "u_cal")
    u_w = _nonnegative(u_w, "u_w")
    u_b = _nonnegative(u_b, "u_b")
    if policy is not Policy.ISO_2011 and u_b > 0:
        raise InputError(f"u_b: only the 2011 policy takes an uncertainty of b (policy {policy})")
    if workpiece is not None:
        if u_w > 0:
            raise InputError("--u-w: give u_w or its inputs (--alpha, --form ...), not both")
        if workpiece.length is None:
            workpiece = replace(workpiece, length=abs(calibrated))
        u_w = workpiece.u()
    deviations: list[str] = []
    # u_p from fewer repeats is itself too uncertain to state (2 repeats: one degree of
    # freedom), whatever the combination rule: the minimum holds for every policy
    shortfall = repeat_shortfall(y.size, series)
    if shortfall and not allow_few_repeats:
        raise InputError(
            f"{name}: {'; '.join(shortfall)} (policy {policy}, --u-p {method}); "
            "--allow-few-repeats proceeds and records the deviation"
        )
    deviations = shortfall
    u_p = repeatability(y, series, method, allow_few_repeats=allow_few_repeats)
    mean = float(np.mean(y))
    check_same_unit(mean, calibrated, f"{name}: the repeats' mean")
    b = mean - calibrated
    u_probe = probe_contribution(probe_error, machine_class)
    u, expanded = combine(policy, b=b, u_p=u_p, u_cal=u_cal, u_w=u_w, u_b=u_b, u_probe=u_probe, k=k)
    corrected = policy is Policy.ISO_2011
    result = mean - b if corrected else mean
    used_b = {Policy.ISO_2004: 0.0, Policy.ISO_2011: u_b, Policy.PAPER_003: abs(b)}[policy]
    part_result = None
    if part is not None:
        readings = np.asarray(part, dtype=float).ravel()
        if readings.size == 0 or not np.all(np.isfinite(readings)):
            raise InputError(f"{part_name}: the part's readings must be finite numbers")
        y_part = float(np.mean(readings))
        check_same_unit(y_part, calibrated, f"--part {part_name}: the readings' mean")
        value = y_part - b if corrected else y_part
        part_result = PartResult(
            name=part_name,
            n=int(readings.size),
            mean=y_part,
            bias_corrected=corrected,
            result=value,
            U=expanded,
            decision=None if tolerance is None else decide(value, expanded, tolerance, unit="mm"),
        )
    decision = None
    if tolerance is not None and part is None:
        decision = decide(result, expanded, tolerance, unit="mm")
    return ISO15530Budget(
        policy=policy,
        repeatability_method=method,
        n=int(y.size),
        mean=mean,
        calibrated=calibrated,
        b=b,
        u_p=u_p,
        u_cal=u_cal,
        u_w=u_w,
        u_b=used_b,
        u_probe=u_probe,
        probe_error=float(probe_error),
        machine_class=machine_class,
        k=float(k),
        u=u,
        U=expanded,
        result=result,
        decision=decision,
        name=name,
        provenance=dict(provenance or {}),
        deviations=tuple(deviations),
        part=part_result,
        workpiece=workpiece,
    )
