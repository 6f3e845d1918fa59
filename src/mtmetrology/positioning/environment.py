"""Environmental correction of laser-interferometer positioning readings.

A laser interferometer counts fringes of its wavelength in air ``λ = λ_vac / n``; the
displacement it reports is right only for the refractive index ``n_0`` it assumed.  The
axis is also measured at a material temperature ``t`` other than the reference
temperature 20 °C of ISO 1, so the positions are normalised to 20 °C with the expansion
coefficient ``α`` of the material they are stated for (the nominal differential expansion,
NDE, correction).  With the laser zeroed at the datum target ``P_0`` the reported
displacement is ``d = P_i − P_0 + x_ij`` and the corrected one

    d_c = f · d,    f = (n_0 / n) / (1 + α (t − 20 °C)),

so the corrected deviation is ``x_c = x + (f − 1)(P_i − P_0 + x)`` and the correction is
undone exactly by ``x = (x_c − (f − 1)(P_i − P_0)) / f`` (:func:`correct`,
:func:`uncorrect`).

The refractive index of air is the updated Edlén equation of Birch and Downs (1993, 1994)
as the NIST Engineering Metrology Toolbox states it (Stone and Zimmerman, *Index of
Refraction of Air*, Appendix A-IV, without NIST's own 292.75/T modification of the water
vapour term), with σ = 1/λ_vac in µm⁻¹, p in Pa, t in °C and the partial pressure of water
vapour p_w in Pa::

    (n_s − 1)·10⁸ = 8342.54 + 2406147/(130 − σ²) + 15998/(38.9 − σ²)
    n_tp − 1 = p (n_s − 1)/96095.43 · [1 + 10⁻⁸ (0.601 − 0.00972 t) p] / (1 + 0.003661 t)
    n = n_tp − 10⁻¹⁰ p_w (3.7345 − 0.0401 σ²)

and the saturation vapour pressure over water of the same appendix (A-I, IAPWS 1997,
p_w = RH/100 · p_sv).

References
----------
Edlén, B. (1966). The refractive index of air. *Metrologia* 2, 71–80.
Birch, K. P., Downs, M. J. (1993). An updated Edlén equation for the refractive index of
air. *Metrologia* 30, 155–162; (1994) Correction … *Metrologia* 31, 315–316.
Stone, J. A., Zimmerman, J. H. *Index of Refraction of Air*, NIST Engineering Metrology
Toolbox, https://emtoolbox.nist.gov/Wavelength/Documentation.asp, Appendix A.
IAPWS (2007). Revised Release on the IAPWS Industrial Formulation 1997 for the
Thermodynamic Properties of Water and Steam, eq. 30 (saturation pressure) and Table 35
(its verification values, reproduced in the tests).
ISO 1:2016, standard reference temperature 20 °C.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.errors import InputError

__all__ = [
    "HENE_VACUUM_NM",
    "REFERENCE_C",
    "correct",
    "correction_factor",
    "refractive_index",
    "saturation_vapour_pressure",
    "uncorrect",
]

#: Vacuum wavelength of a stabilised He-Ne laser, nm (the iodine-stabilised 632.991 nm line).
HENE_VACUUM_NM = 632.991
#: Reference temperature of dimensional measurements (ISO 1), °C.
REFERENCE_C = 20.0

# IAPWS-IF97 saturation-pressure constants (NIST appendix A-I)
_K = (
    1.16705214528e3,
    -7.24213167032e5,
    -1.70738469401e1,
    1.20208247025e4,
    -3.23255503223e6,
    1.49151086135e1,
    -4.82326573616e3,
    4.05113405421e5,
    -2.38555575678e-1,
    6.50175348448e2,
)


def saturation_vapour_pressure(t_c: float | np.ndarray) -> float | np.ndarray:
    """Saturation vapour pressure over water, Pa (IAPWS 1997; NIST appendix A-I).

    Parameters
    ----------
    t_c : float or ndarray
        Air temperature, °C (0 to 100 °C, the range of the formula over liquid water).
    """
    t = np.asarray(t_c, dtype=float) + 273.15
    k = _K
    omega = t + k[8] / (t - k[9])
    a = omega**2 + k[0] * omega + k[1]
    b = k[2] * omega**2 + k[3] * omega + k[4]
    c = k[5] * omega**2 + k[6] * omega + k[7]
    x = -b + np.sqrt(b**2 - 4 * a * c)
    return 1e6 * (2 * c / x) ** 4


def refractive_index(
    t_c: float | np.ndarray,
    p_pa: float | np.ndarray,
    rh_percent: float | np.ndarray = 0.0,
    wavelength_nm: float = HENE_VACUUM_NM,
) -> float | np.ndarray:
    """Refractive index of air by the updated Edlén equation (Birch and Downs 1994).

    Parameters
    ----------
    t_c : float or ndarray
        Air temperature, °C.
    p_pa : float or ndarray
        Air pressure, Pa.
    rh_percent : float or ndarray
        Relative humidity, %.
    wavelength_nm : float
        Vacuum wavelength, nm.

    Returns
    -------
    float or ndarray
        n (module notes for the equation).

    Raises
    ------
    InputError
        A condition outside the range the equation is stated for (t −40 to 100 °C,
        p 10 kPa to 140 kPa, RH 0 to 100 %).
    """
    t = np.asarray(t_c, dtype=float)
    p = np.asarray(p_pa, dtype=float)
    rh = np.asarray(rh_percent, dtype=float)
    for name, v, lo, hi in (
        ("air temperature", t, -40.0, 100.0),
        ("air pressure", p, 1e4, 1.4e5),
        ("humidity", rh, 0.0, 100.0),
    ):
        if not np.all((v >= lo) & (v <= hi)):
            raise InputError(f"{name}: {np.ravel(v)[0]:g} outside {lo:g} to {hi:g}")
    s2 = (1e3 / wavelength_nm) ** 2
    ns1 = 1e-8 * (8342.54 + 2406147.0 / (130.0 - s2) + 15998.0 / (38.9 - s2))
    ntp1 = p * ns1 / 96095.43 * (1.0 + 1e-8 * (0.601 - 0.00972 * t) * p) / (1.0 + 0.003661 * t)
    pw = rh / 100.0 * saturation_vapour_pressure(np.clip(t, 0.0, None))
    n = 1.0 + ntp1 - 1e-10 * pw * (3.7345 - 0.0401 * s2)
    return float(n) if np.ndim(n) == 0 else n


def correction_factor(
    n_air: float, material_c: float, alpha_per_k: float, n_assumed: float = 1.0
) -> float:
    """``f = (n_0/n)/(1 + α (t − 20 °C))``: the factor on the displacement (module notes)."""
    return (n_assumed / n_air) / (1.0 + alpha_per_k * (material_c - REFERENCE_C))


def correct(x: np.ndarray, span: np.ndarray, f: float) -> np.ndarray:
    """Corrected deviations ``x + (f − 1)(span + x)``.

    Parameters
    ----------
    x : ndarray, shape (m, n, 2)
        Deviations as read, mm.
    span : ndarray, shape (m,)
        ``P_i − P_0``: each target's distance from the laser datum, mm.
    f : float
        :func:`correction_factor`.
    """
    return x + (f - 1.0) * (span[:, None, None] + x)


def uncorrect(x_c: np.ndarray, span: np.ndarray, f: float) -> np.ndarray:
    """Inverse of :func:`correct`: the deviations as read."""
    return (x_c - (f - 1.0) * span[:, None, None]) / f
