"""The validation campaign of a task uncertainty: a calibrated gauge probed as bipoints.

Sepahi Boroujeni (2021), §6.4–6.5: the two faces of a calibrated gauge block are probed
at several (B, C) indexations (15 tasks a face, "side A" and "side B"); every pairing of
a side-A point with a side-B point is one bipoint (15² = 225), compensated with the
calibration and given a full-covariance interval y ± U
(:func:`mtmetrology.omm.task.task_uncertainty`, GUF). The calibrated length carried to
the measurement temperature (eqs. 6-17 and 6-19, :func:`~mtmetrology.omm.reference.
thermal_reference_value`) is the reference; eq. 6-16 gives the probability that each
interval holds it, and the mean over the bipoints is the delivered coverage (the thesis:
90 % with cov(e), 39 % without, 203 of 225 intervals holding y_cal). The same bipoints
without E in the budget are the ablation.

Acceptance. If the N intervals were independent, the number holding y_cal would be
binomial (N, p); the two-sided 99 % region [F⁻¹(0.005), F⁻¹(0.995)]/N is reported. The
bipoints share their ends (each point enters 15 pairs), so the real spread is wider: the
region is a yardstick, not a test, for a campaign of paired points.

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, §6.4 (eqs. 6-16 to 6-19), §6.5.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from mtmetrology.errors import InputError
from mtmetrology.fitting.features import GaugeLength
from mtmetrology.kinematics.machine import Machine
from mtmetrology.omm.reference import coverage_probability
from mtmetrology.omm.task import task_uncertainty
from mtmetrology.units import from_internal

__all__ = ["GaugeValidation", "binomial_region", "validate_gauge"]

KIND = "task-validation"


def binomial_region(n: int, p: float, level: float = 0.99) -> tuple[float, float]:
    """Two-sided acceptance region of a coverage fraction over n independent intervals.

    Returns
    -------
    (low, high) : fractions
        [F⁻¹((1 − level)/2), F⁻¹((1 + level)/2)] / n of the binomial (n, p).
    """
    dist = stats.binom(n, p)
    return float(dist.ppf((1 - level) / 2) / n), float(dist.ppf((1 + level) / 2) / n)


@dataclass(frozen=True)
class GaugeValidation:
    """Coverage of bipoint intervals against a calibrated length.

    Attributes
    ----------
    reference_value, reference_uncertainty : float, mm
        y_cal and u_cal at the measurement temperature.
    pairs : (N, 2) ndarray of int
        Side-A and side-B index of each bipoint.
    length, length_uncompensated : (N,) ndarray, mm
        Compensated and nominal-model lengths.
    expanded_uncertainty : (N,) ndarray, mm
        U = k u of each compensated length (GUF, the full budget).
    coverage : (N,) ndarray
        Eq. 6-16 of each interval.
    expanded_uncertainty_without_e, coverage_without_e : (N,) ndarray or None
        The same without the unexplained volumetric error (None when no cov(e) given).
    p : float
        Coverage probability the intervals are stated for.
    thermal_reference : dict or None
        The ``uncertainty-result`` document of y_cal carried from 20 °C to the measurement
        temperature (eqs. 6-17 to 6-19), recorded as ``reference.thermal`` when the request
        gave the calibrated value at 20 °C (:func:`~mtmetrology.omm.validation_request.
        validate_gauge_from_files`).
    source : dict or None
        The files of the request, recorded as ``source`` in the document.
    coverage_factor : (N,) ndarray or None
        k of each U (the GUF's, for p and its ν_eff), stated beside the U's.
    """

    reference_value: float
    reference_uncertainty: float
    pairs: np.ndarray
    length: np.ndarray
    length_uncompensated: np.ndarray
    expanded_uncertainty: np.ndarray
    coverage: np.ndarray
    expanded_uncertainty_without_e: np.ndarray | None
    coverage_without_e: np.ndarray | None
    p: float
    thermal_reference: dict | None = None
    source: dict | None = None
    coverage_factor: np.ndarray | None = None

    @property
    def mean_coverage(self) -> float:
        """p̄, the mean of eq. 6-16 over the bipoints."""
        return float(self.coverage.mean())

    @property
    def mean_coverage_without_e(self) -> float | None:
        return None if self.coverage_without_e is None else float(self.coverage_without_e.mean())

    @property
    def holding(self) -> int:
        """Intervals y ± U that hold y_cal."""
        return int(np.sum(np.abs(self.length - self.reference_value) <= self.expanded_uncertainty))

    @property
    def acceptance_region(self) -> tuple[float, float]:
        """Binomial two-sided 99 % region of the coverage fraction (independent intervals)."""
        return binomial_region(len(self.length), self.p)

    def to_dict(self) -> dict:
        """The ``task-validation`` document (µm for uncertainties and errors, mm for lengths)."""
        low, high = self.acceptance_region

        def um(x):
            return None if x is None else from_internal(np.asarray(x), "µm").tolist()

        summary = {
            "bipoints": len(self.length),
            "p": self.p,
            "mean_coverage": self.mean_coverage,
            "holding": self.holding,
            "mean_U_um": float(from_internal(self.expanded_uncertainty.mean(), "µm")),
            "mean_coverage_without_e": self.mean_coverage_without_e,
            "binomial_region_99": [low, high],
            "mean_length_mm": float(self.length.mean()),
            "std_length_um": float(from_internal(self.length.std(ddof=1), "µm"))
            if len(self.length) > 1
            else None,
            "mean_length_uncompensated_mm": float(self.length_uncompensated.mean()),
        }
        reference = {
            "value_mm": self.reference_value,
            "u_um": float(from_internal(self.reference_uncertainty, "µm")),
        }
        if self.thermal_reference is not None:
            reference["thermal"] = self.thermal_reference
        doc = {
            "kind": KIND,
            "version": 1,
            "measurement_model": "bipoint length l = ‖q₂ − q₁‖ − d_tip of compensated points; "
            "reference y_cal = y_cal,20 (1 + αΔT) (eqs. 6-17, 6-19); coverage eq. 6-16",
            "reference": reference,
            "summary": summary,
            "bipoints": {
                "pairs": self.pairs.tolist(),
                "length_mm": self.length.tolist(),
                "length_uncompensated_mm": self.length_uncompensated.tolist(),
                "U_um": um(self.expanded_uncertainty),
                "k": None if self.coverage_factor is None else self.coverage_factor.tolist(),
                "coverage": self.coverage.tolist(),
                "U_without_e_um": um(self.expanded_uncertainty_without_e),
                "coverage_without_e": None
                if self.coverage_without_e is None
                else self.coverage_without_e.tolist(),
            },
        }
        if self.source is not None:
            doc["source"] = dict(self.source)
        return doc

    @classmethod
    def from_dict(cls, doc: dict) -> GaugeValidation:
        """Inverse of :meth:`to_dict`."""
        b = doc["bipoints"]
        mm = 1e-3  # µm -> mm

        def arr(key, scale=1.0):
            return None if b[key] is None else np.array(b[key], float) * scale

        return cls(
            float(doc["reference"]["value_mm"]),
            float(doc["reference"]["u_um"]) * mm,
            np.array(b["pairs"], int).reshape(-1, 2),
            arr("length_mm"),
            arr("length_uncompensated_mm"),
            arr("U_um", mm),
            arr("coverage"),
            arr("U_without_e_um", mm),
            arr("coverage_without_e"),
            float(doc["summary"]["p"]),
            thermal_reference=doc["reference"].get("thermal"),
            source=doc.get("source"),
            coverage_factor=None if b.get("k") is None else np.array(b["k"], float),
        )


def validate_gauge(
    machine: Machine,
    side_a: np.ndarray,
    side_b: np.ndarray,
    parameters: np.ndarray,
    calibration_covariance: np.ndarray,
    reference_value: float,
    reference_uncertainty: float,
    *,
    tip_diameter: float,
    long_term_covariance: np.ndarray | None = None,
    recalibrated: bool = False,
    reading_covariance_a: np.ndarray | None = None,
    reading_covariance_b: np.ndarray | None = None,
    unexplained_covariance: np.ndarray | None = None,
    p: float = 0.95,
) -> GaugeValidation:
    """Coverage of compensated gauge lengths over every side-A × side-B bipoint.

    Parameters
    ----------
    machine : Machine
        With exactly three linear axes.
    side_a, side_b : (n_a, n_axes), (n_b, n_axes) arrays
        Readings (mm, rad) of the points probed on each face.
    parameters, calibration_covariance : (P,), (P, P) arrays
        The calibration's δ̂ that compensates and its U_θ.
    reference_value, reference_uncertainty : float, mm
        y_cal and u_cal at the measurement temperature (e.g. from
        :func:`~mtmetrology.omm.reference.thermal_reference_value`).
    tip_diameter : float, mm
        Effective tip diameter subtracted from the centre distance.
    long_term_covariance, recalibrated
        As in :func:`~mtmetrology.omm.task.task_uncertainty`.
    reading_covariance_a, reading_covariance_b : (n, n_axes, n_axes) arrays, optional
        Repeatability v of each reading.
    unexplained_covariance : (3, 3) array, optional
        cov(e), mm²; when given, the ablation without it is computed too.
    p : float
        Coverage probability of each interval.

    Returns
    -------
    GaugeValidation

    Raises
    ------
    InputError
        An empty side, readings that do not have the machine's axes, covariances that do
        not match, or what :func:`~mtmetrology.omm.task.task_uncertainty` refuses.
    """
    a, b = np.atleast_2d(side_a), np.atleast_2d(side_b)
    for name, s in (("side A", a), ("side B", b)):
        if s.shape[0] == 0 or s.shape[1] != machine.n_axes:
            raise InputError(
                f"{name}: expected readings of {machine.n_axes} axes "
                f"({', '.join(machine.axis_names)}), got shape {s.shape}"
            )
    for name, v, s in (("A", reading_covariance_a, a), ("B", reading_covariance_b, b)):
        if v is not None and np.shape(v) != (len(s), machine.n_axes, machine.n_axes):
            raise InputError(f"reading covariance of side {name}: shape {np.shape(v)} != readings")
    gauge = GaugeLength(tip_diameter=tip_diameter)
    zero = np.zeros(machine.n_params)
    pairs = np.array([(i, j) for i in range(len(a)) for j in range(len(b))], int)
    n = len(pairs)
    length, nominal, big_u, k_u = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    big_u0 = np.empty(n) if unexplained_covariance is not None else None
    for k, (i, j) in enumerate(pairs):
        readings = np.vstack([a[i], b[j]])
        v = None
        if reading_covariance_a is not None or reading_covariance_b is not None:
            va = zeros_if_none(reading_covariance_a, i, machine.n_axes)
            vb = zeros_if_none(reading_covariance_b, j, machine.n_axes)
            v = np.stack([va, vb])
        r = task_uncertainty(
            machine,
            readings,
            parameters,
            calibration_covariance,
            gauge,
            long_term_covariance=long_term_covariance,
            recalibrated=recalibrated,
            reading_covariance=v,
            unexplained_covariance=unexplained_covariance,
            p=p,
        )
        length[k], big_u[k], k_u[k] = r.guf.estimate[0], r.guf.outputs[0].U, r.guf.outputs[0].k
        nominal[k] = float(gauge.value(machine.forward(readings, zero)))
        if big_u0 is not None:
            # the budget groups add exactly to u², so the ablation is u² less the E group
            share_e = float(r.shares["unexplained_volumetric_error"][0])
            big_u0[k] = big_u[k] * max(1.0 - share_e, 0.0) ** 0.5
    cov = coverage_probability(length, big_u, reference_value, reference_uncertainty)
    cov0 = (
        None
        if big_u0 is None
        else coverage_probability(length, big_u0, reference_value, reference_uncertainty)
    )
    return GaugeValidation(
        float(reference_value),
        float(reference_uncertainty),
        pairs,
        length,
        nominal,
        big_u,
        np.atleast_1d(cov),
        big_u0,
        None if cov0 is None else np.atleast_1d(cov0),
        p,
        coverage_factor=k_u,
    )


def zeros_if_none(v: np.ndarray | None, i: int, n_axes: int) -> np.ndarray:
    """The i-th reading covariance, or zeros (perfect repeatability) when none given."""
    return np.zeros((n_axes, n_axes)) if v is None else np.asarray(v)[i]
