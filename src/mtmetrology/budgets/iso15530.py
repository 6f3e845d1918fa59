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
from dataclasses import dataclass, field

import numpy as np

from mtmetrology.budgets.choices import Policy, RepeatabilityMethod
from mtmetrology.errors import InputError
from mtmetrology.uncertainty.conformity import ConformityDecision, Tolerance, decide
from mtmetrology.uncertainty.outputs import Output
from mtmetrology.units import from_internal, to_internal

__all__ = [
    "BUDGET_KIND",
    "PROBE_THRESHOLD",
    "ISO15530Budget",
    "budget_output",
    "combine",
    "iso15530_3_budget",
    "probe_contribution",
    "repeatability",
]

BUDGET_KIND = "iso15530-3-budget"
_VERSION = 1

#: Probe systematic error below which the probe term is negligible, by machine class (mm).
PROBE_THRESHOLD = {"small": to_internal(1.0, "µm"), "large": to_internal(3.0, "µm")}

#: ISO 15530-3 usage of the repeatability: cycles per series and repeats in all.
MIN_CYCLES_PER_SERIES = 10
MIN_REPEATS = 20


def _nonnegative(value: float, name: str) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name}: expected a number, got {value!r}") from None
    if not math.isfinite(x) or x < 0:
        raise InputError(f"{name}: must be a finite number >= 0, got {value!r}")
    return x


def repeatability(
    values: np.ndarray,
    series: np.ndarray | None = None,
    method: RepeatabilityMethod | str = RepeatabilityMethod.SAMPLE,
) -> float:
    """u_p from repeated measurement cycles (Mutilba et al., Eq. 3).

    Parameters
    ----------
    values : (n,) array
        One result per cycle.
    series : (n,) array, optional
        Series label of each value (a day, a re-clamping ...); one series without it.
    method : RepeatabilityMethod
        ``sample``: u_p = √(Σ(y_i − ȳ)² / (n − 1)) over all values (n ≥ 2).
        ``max-over-series``: the largest such standard deviation over the series, each of
        at least 10 cycles, at least 20 repeats in all (ISO 15530-3 usage).

    Returns
    -------
    float
        u_p, in the unit of ``values``.

    Raises
    ------
    InputError
        Too few values for the method.
    """
    y = np.asarray(values, dtype=float).ravel()
    method = RepeatabilityMethod(method)
    if method is RepeatabilityMethod.SAMPLE:
        if y.size < 2:
            raise InputError(f"u_p: {y.size} repeated value(s), at least 2 needed")
        return float(np.std(y, ddof=1))
    labels = np.zeros(y.size, dtype=int) if series is None else np.asarray(series)
    if y.size < MIN_REPEATS:
        raise InputError(
            f"u_p (max-over-series): {y.size} repeats, ISO 15530-3 usage needs at least "
            f"{MIN_REPEATS}"
        )
    worst = 0.0
    for label in np.unique(labels):
        s = y[labels == label]
        if s.size < MIN_CYCLES_PER_SERIES:
            raise InputError(
                f"u_p (max-over-series): series {str(label)!r} has {s.size} cycles, at least "
                f"{MIN_CYCLES_PER_SERIES} needed"
            )
        worst = max(worst, float(np.std(s, ddof=1)))
    return worst


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
        ISO 14253-1 decision of ``result`` ± U against the tolerance, if one was given.
    name : str
        Name of the characteristic.
    provenance : dict
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
        decision = None
        if doc.get("decision") is not None:
            d = doc["decision"]
            t = d["tolerance"]
            decision = decide(
                doc["result"],
                doc["U"],
                Tolerance(t["nominal"], t["lower_deviation"], t["upper_deviation"]),
                guard_band_factor=d["guard_band_factor"],
                unit=d.get("unit"),
            )
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
            decision=decision,
            name=str(doc.get("name", "characteristic")),
            provenance=dict(doc.get("provenance", {})),
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
) -> ISO15530Budget:
    """ISO 15530-3 budget of one characteristic from repeated on-machine measurements.

    Parameters
    ----------
    values : (n,) array
        Results of the repeated cycles (mm).
    calibrated : float
        x_cal, the calibrated value of the same characteristic (mm).
    u_cal, u_w, u_b : float
        Standard uncertainties (mm, ≥ 0): calibration, workpiece variation, bias estimate
        (``2011`` only).
    series : (n,) array, optional
        Series labels for ``max-over-series``.
    policy, repeatability_method
        See :class:`Policy` and :func:`repeatability`.
    probe_error, machine_class
        See :func:`probe_contribution`.
    k : float
        Coverage factor.
    tolerance : Tolerance, optional
        Specification; the ISO 14253-1 decision of the reported result ± U is attached.

    Returns
    -------
    ISO15530Budget
        b = ȳ − x_cal; u and U by :func:`combine`.

    Raises
    ------
    InputError
        Negative or non-finite uncertainty, too few repeats, unknown policy.
    """
    y = np.asarray(values, dtype=float).ravel()
    if not np.all(np.isfinite(y)):
        raise InputError("values: every repeated result must be a finite number")
    policy = Policy(policy)
    method = RepeatabilityMethod(repeatability_method)
    u_cal = _nonnegative(u_cal, "u_cal")
    u_w = _nonnegative(u_w, "u_w")
    u_b = _nonnegative(u_b, "u_b")
    if policy is not Policy.ISO_2011 and u_b > 0:
        raise InputError(f"u_b: only the 2011 policy takes an uncertainty of b (policy {policy})")
    u_p = repeatability(y, series, method)
    mean = float(np.mean(y))
    b = mean - float(calibrated)
    u_probe = probe_contribution(probe_error, machine_class)
    u, expanded = combine(policy, b=b, u_p=u_p, u_cal=u_cal, u_w=u_w, u_b=u_b, u_probe=u_probe, k=k)
    result = mean - b if policy is Policy.ISO_2011 else mean
    used_b = {Policy.ISO_2004: 0.0, Policy.ISO_2011: u_b, Policy.PAPER_003: abs(b)}[policy]
    decision = None if tolerance is None else decide(result, expanded, tolerance, unit="mm")
    return ISO15530Budget(
        policy=policy,
        repeatability_method=method,
        n=int(y.size),
        mean=mean,
        calibrated=float(calibrated),
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
    )
