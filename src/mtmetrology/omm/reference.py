"""Calibrated reference values at the measurement temperature, and coverage probability.

To check an on-machine uncertainty statement against a calibrated workpiece (gauge
block, precision sphere), the calibrated value at 20 °C is carried to the workpiece
temperature (:func:`thermal_reference_value`, Sepahi Boroujeni (2021), eqs. 6-17 to
6-19, evaluated by the library's GUF) and the probability that an interval y ± U holds
the reference value is the normal probability mass of the reference inside it
(:func:`coverage_probability`, eq. 6-16). Averaged over many intervals, it estimates
the coverage probability the stated U actually delivers (95 % targeted for k = 2).

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, §6.4.

JCGM 100:2008. *Evaluation of measurement data — Guide to the expression of uncertainty
in measurement*, 5.1.2 (law of propagation of uncertainty).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr

from mtmetrology.errors import InputError
from mtmetrology.uncertainty.distributions import Normal
from mtmetrology.uncertainty.guf import GUFResult, guf
from mtmetrology.uncertainty.inputs import InputQuantity, InputSet

__all__ = ["ReferenceValue", "coverage_probability", "thermal_reference_value"]


def _expansion(x: np.ndarray) -> np.ndarray:
    # eq. 6-17: y_cal = y_cal,20 (1 + α ΔT), inputs (..., 3) = (y_cal,20, α, ΔT)
    return x[..., 0] * (1.0 + x[..., 1] * x[..., 2])


def _expansion_jacobian(x: np.ndarray) -> np.ndarray:
    # eq. 6-18 sensitivities: (1 + αΔT, y ΔT, y α)
    y, alpha, dt = x
    return np.array([1.0 + alpha * dt, y * dt, y * alpha])


@dataclass(frozen=True)
class ReferenceValue:
    """A calibrated reference value carried to the measurement temperature.

    Attributes
    ----------
    name : str
        Measurand name (``gauge_length``, ``sphere_diameter`` …).
    value : float
        y_cal (mm).
    standard_uncertainty : float
        u_cal (mm).
    guf : GUFResult
        The propagation (budget of y_cal,20, α and ΔT).
    """

    name: str
    value: float
    standard_uncertainty: float
    guf: GUFResult

    def to_dict(self) -> dict:
        """An ``uncertainty-result`` document (``outputs: [{name, value, unit, u, U, k, p,
        interval}]``, ``method: guf``, the budget)."""
        return {"kind": "uncertainty-result", "version": 1, **self.guf.to_dict()}


def thermal_reference_value(
    calibrated_value: float,
    calibration_uncertainty: float,
    *,
    expansion_coefficient: float,
    expansion_coefficient_uncertainty: float,
    temperature_difference: float,
    temperature_difference_uncertainty: float,
    name: str = "reference_value",
    p: float = 0.95,
) -> ReferenceValue:
    """Calibrated value at the measurement temperature with its standard uncertainty.

    Parameters
    ----------
    calibrated_value : float, mm
        y_cal,20°C, the certificate value at 20 °C.
    calibration_uncertainty : float, mm
        u_cal,20°C, its *standard* uncertainty (a certificate U for k = 2 divided by 2).
    expansion_coefficient, expansion_coefficient_uncertainty : float, 1/°C
        α and u_α of the workpiece.
    temperature_difference, temperature_difference_uncertainty : float, °C
        ΔT of the workpiece from 20 °C during the measurement, and u_ΔT.
    name : str
        Output name in the result.
    p : float
        Coverage probability of the reported interval.

    Returns
    -------
    ReferenceValue

    Raises
    ------
    InputError
        A non-finite value or a negative uncertainty.

    Notes
    -----
    Sepahi Boroujeni (2021), eqs. 6-17 and 6-19 (the law of propagation, eq. 6-18,
    with uncorrelated inputs)::

        y_cal = y_cal,20 (1 + α ΔT)
        u_cal = √((1 + αΔT)² u²_cal,20 + (y_cal,20 ΔT)² u_α² + (y_cal,20 α)² u_ΔT²)

    Examples
    --------
    The gauge block of §6.4: 500.0000 mm, U = 0.3 µm (k = 2), α = 10.8·10⁻⁶ ± 0.15·10⁻⁶
    /°C, ΔT = 1.75 ± 0.005/√3 °C give 500.00945 mm with u_cal = 0.20 µm:

    >>> r = thermal_reference_value(500.0, 0.00015, expansion_coefficient=10.8e-6,
    ...     expansion_coefficient_uncertainty=0.15e-6, temperature_difference=1.75,
    ...     temperature_difference_uncertainty=0.005 / 3 ** 0.5)
    >>> round(r.value, 5), round(r.standard_uncertainty * 1000, 2)
    (500.00945, 0.2)
    """
    values = {
        "calibrated_value": calibrated_value,
        "calibration_uncertainty": calibration_uncertainty,
        "expansion_coefficient": expansion_coefficient,
        "expansion_coefficient_uncertainty": expansion_coefficient_uncertainty,
        "temperature_difference": temperature_difference,
        "temperature_difference_uncertainty": temperature_difference_uncertainty,
    }
    for key, v in values.items():
        if not math.isfinite(float(v)):
            raise InputError(f"{key}: expected a finite number, got {v!r}")
        if key.endswith("uncertainty") and v < 0:
            raise InputError(f"{key}: must be >= 0, got {v!r}")
    inputs = InputSet(
        [
            InputQuantity("y_cal_20", Normal(calibrated_value, calibration_uncertainty), "mm"),
            InputQuantity(
                "alpha",
                Normal(expansion_coefficient, expansion_coefficient_uncertainty),
                "/°C",
            ),
            InputQuantity(
                "delta_T",
                Normal(temperature_difference, temperature_difference_uncertainty),
                "°C",
            ),
        ]
    )
    result = guf(
        _expansion,
        inputs,
        jacobian=_expansion_jacobian,
        p=p,
        output_names=[name],
        output_units=["mm"],
    )
    return ReferenceValue(
        name, float(result.estimate[0]), float(result.standard_uncertainty[0]), result
    )


def coverage_probability(
    value: np.ndarray,
    expanded_uncertainty: np.ndarray,
    reference_value: float,
    reference_uncertainty: float,
) -> np.ndarray:
    """Probability that intervals y ± U contain the reference value (eq. 6-16).

    Parameters
    ----------
    value, expanded_uncertainty : (n,) array or float, mm
        Results y and their expanded uncertainties U (U >= 0).
    reference_value, reference_uncertainty : float, mm
        y_cal and u_cal of the calibrated workpiece (u_cal = 0: an indicator).

    Returns
    -------
    ndarray or float
        p = Φ((y + U − y_cal)/u_cal) − Φ((y − U − y_cal)/u_cal) per interval. Its mean
        over many intervals estimates the delivered coverage probability.

    Raises
    ------
    InputError
        Non-finite numbers or negative uncertainties.

    Notes
    -----
    Sepahi Boroujeni (2021), eq. 6-16: the mass of N(y_cal, u_cal²) inside [y − U, y + U].
    Since u_cal ≪ U in practice, p is nearly an indicator of y_cal ∈ [y − U, y + U].

    Examples
    --------
    Table 7-1 gauge length 499.9966 mm with U = 18 µm against 500.0095 mm, u_cal = 0.2 µm:

    >>> float(coverage_probability(499.9966, 0.018, 500.0095, 0.0002))
    1.0
    """
    y = np.asarray(value, float)
    big_u = np.asarray(expanded_uncertainty, float)
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(big_u))):
        raise InputError("value and expanded_uncertainty must be finite")
    if np.any(big_u < 0):
        raise InputError("expanded_uncertainty must be >= 0")
    if not (math.isfinite(reference_value) and math.isfinite(reference_uncertainty)):
        raise InputError("reference value and uncertainty must be finite")
    if reference_uncertainty < 0:
        raise InputError("reference_uncertainty must be >= 0")
    low, high = y - big_u - reference_value, y + big_u - reference_value
    if reference_uncertainty == 0:
        p = ((low <= 0) & (high >= 0)).astype(float)
    else:
        p = ndtr(high / reference_uncertainty) - ndtr(low / reference_uncertainty)
    return p if p.ndim else float(p)
