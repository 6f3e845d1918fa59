"""The CMM's specification and test uncertainties at the budget's length (Salacheep 2016).

Computed by :func:`mtmetrology.cmm.budget.cmm_statement`.

Statements of the specification (Appendix 1; the source's PMM-C 700P and KOBA plate)::

    U_CMM(l)   = sqrt(A² + (B l)²)          CMM uncertainty, k = 2 (A = 0.52 µm, B = 1.4e-3)
    U_plate(l) = sqrt(A_p² + (B_p l)²)      plate certificate, k = 2 (0.26 µm, 1.9e-3)
    MPE_E(L)   = a + L/K                    maximum permissible error (0.6 µm + L/600)

and the test uncertainties of ISO/TS 23165 (eqs 3.10–3.13)::

    u(P) = sqrt((F/2)² + u²(F))                                        (3.10)
    u(E) = sqrt(u²(ε_cal) + u²(ε_α) + u²(ε_t) + u²(ε_align) + u²(ε_fixt))  (3.11)
    U(P) = k u(P),  U(E) = k u(E),  k = 2                              (3.12, 3.13)

with, for the material standard of size of length l (the plate length of the budget):
``u(ε_cal) = U_plate(l)/2``; ``u(ε_α) = l |t − 20 °C| u(α)``, ``u(α)`` the CTE half-width
over √3 (rectangular); ``u(ε_t) = l α u(t)``, ``u(t)`` from the part thermometer (k = 2)
and the temperature spread (rectangular); ``u(ε_align) = l(1 − cos θ)/√3`` (rectangular,
θ = asin(e/l)); ``u(ε_fixt)`` given.  F is the form error of the test sphere and ``u(F)``
its standard uncertainty, both from its certificate.  The source labels eq. 3.11 "u(P)"; its
terms are those of the length test, E (digest of Salacheep 2016, §2.17 a).

References
----------
Salacheep, P. (2016). *Error Compensation and Uncertainty Evaluation of CMMs Based on
Kinematic Error Models and Gaussian Processes*. MPhil thesis, Brunel University London,
§3.8.2, eqs 3.10–3.13, Appendix 1.
ISO/TS 23165:2006, *Geometrical product specifications (GPS) — Guidelines for the
evaluation of coordinate measuring machine (CMM) test uncertainty*, §6.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

__all__ = ["CMMStatement", "LengthLaw", "SpecificationSpec"]

COVERAGE_FACTOR = 2.0


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class LengthLaw(_Strict):
    """``U(l) = sqrt(a² + (b l)²)`` µm, l in mm (k = 2)."""

    a_um: float = Field(ge=0)
    b_um_per_mm: float = Field(ge=0)

    def expanded(self, length_mm: float) -> float:
        """U at ``length_mm``, µm.

        Examples
        --------
        >>> round(LengthLaw(a_um=0.52, b_um_per_mm=1.4e-3).expanded(532.0), 3)
        0.908
        """
        return float(np.hypot(self.a_um, self.b_um_per_mm * length_mm))


class SpecificationSpec(_Strict):
    """The CMM's and the plate's stated performance, and the test artefacts' data."""

    cmm_U: LengthLaw
    plate_U: LengthLaw
    mpe_a_um: float = Field(ge=0)
    mpe_length_divisor: float = Field(gt=0)
    sphere_form_um: float = Field(ge=0)
    sphere_form_u_um: float = Field(ge=0)
    fixturing_u_um: float = Field(default=0.0, ge=0)


@dataclass(frozen=True)
class CMMStatement:
    """Stated U and MPE at the budget's length and the test uncertainties u(P), u(E).

    Attributes
    ----------
    length_mm : float
    U_cmm_um, U_plate_um, mpe_um : float
        Specification values at ``length_mm`` (k = 2 for the U's).
    u_P_um, u_E_um : float
        Eqs 3.10 and 3.11.
    E_items_um : dict
        ``u(ε_cal), u(ε_α), u(ε_t), u(ε_align), u(ε_fixt)`` in µm.
    k : float
    """

    length_mm: float
    U_cmm_um: float
    U_plate_um: float
    mpe_um: float
    u_P_um: float
    u_E_um: float
    E_items_um: dict
    k: float = COVERAGE_FACTOR

    @property
    def U_P_um(self) -> float:
        """Eq. 3.12."""
        return self.k * self.u_P_um

    @property
    def U_E_um(self) -> float:
        """Eq. 3.13."""
        return self.k * self.u_E_um

    def to_dict(self) -> dict:
        """JSON form (µm, k stated)."""
        return {
            "length_mm": self.length_mm,
            "k": self.k,
            "U_cmm_um": self.U_cmm_um,
            "U_plate_um": self.U_plate_um,
            "mpe_um": self.mpe_um,
            "u_P_um": self.u_P_um,
            "U_P_um": self.U_P_um,
            "u_E_um": self.u_E_um,
            "U_E_um": self.U_E_um,
            "E_items_um": dict(self.E_items_um),
        }

    @classmethod
    def from_dict(cls, doc: dict) -> CMMStatement:
        """Read :meth:`to_dict`'s form back."""
        return cls(
            float(doc["length_mm"]),
            float(doc["U_cmm_um"]),
            float(doc["U_plate_um"]),
            float(doc["mpe_um"]),
            float(doc["u_P_um"]),
            float(doc["u_E_um"]),
            {k: float(v) for k, v in doc["E_items_um"].items()},
            float(doc["k"]),
        )
