"""u_w of an ISO 15530-3 budget from its inputs: the production parts' variation of the
expansion coefficient, their temperature and their form.

ISO 15530-3 (2004 and 2011, clause 7) names u_w the standard uncertainty from the
variation in material and manufacture between the calibrated workpiece and the parts
measured like it: the expansion coefficient, form, roughness, elasticity, plasticity.  The
thermal part is written there as u_w = (t − 20 °C)·u_α·l; the form part is left to the
user.  Here u_w is evaluated from the inputs by the law of propagation of uncertainty
(JCGM 100:2008, 5.1.2), on the measurement model of a part's deviation from the reference
workpiece:

    δ = L·[(α + δα)·(T − 20 °C + δT) − α·(T − 20 °C)] + δ_F

- δα: the part's expansion coefficient differs from α by δα, rectangular of half-width
  a_α (the spread of the material's α between batches): u_α = a_α/√3 (JCGM 100:2008, 4.3.7);
- δT: the part's temperature is known to u_T (standard uncertainty, K), relative to the
  reference workpiece's at its measurement;
- δ_F: the part's form deviation F (peak to valley) moves a size taken from a finite
  number of points anywhere within ±F/2 of the part's own: rectangular, u_F = F/(2√3)
  (an assumption stated here, as the standard gives no rule for it).

δα, δT and δ_F are independent with zero mean, so the variance is exact, including the
product term (JCGM 100:2008, 5.1.2, note: the second-order term of a product):

    u_w² = L²·[(T − 20 °C)²·u_α² + α²·u_T² + u_α²·u_T²] + F²/12

Its first term is the standard's u_w = (t − 20 °C)·u_α·l.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mtmetrology.errors import InputError
from mtmetrology.io.plausibility import check_temperatures, checked_number
from mtmetrology.units import from_internal

__all__ = ["FORMULA", "REFERENCE_TEMPERATURE", "WorkpieceVariation", "checked_number"]

#: ISO 1:2016 reference temperature of dimensional specifications (°C).
REFERENCE_TEMPERATURE = 20.0

FORMULA = (
    "u_w = √(L²·[(T − 20 °C)²·u_α² + α²·u_T² + u_α²·u_T²] + F²/12), u_α = a_α/√3 "
    "(ISO 15530-3, clause 7: u_w = (t − 20 °C)·u_α·l; JCGM 100:2008, 5.1.2)"
)


@dataclass(frozen=True)
class WorkpieceVariation:
    """The inputs of u_w (module notes) in internal units.

    Attributes
    ----------
    length : float or None
        L (mm, > 0): the length the expansion acts on; None takes the calibrated value's
        magnitude in the budget (:func:`mtmetrology.budgets.iso15530.iso15530_3_budget`).
    alpha : float
        α, the nominal expansion coefficient (1/K); needed with ``u_temperature``.
    alpha_half_width : float
        a_α (1/K, ≥ 0): half-width of the rectangular spread of α between parts.
    temperature : float or None
        T, the parts' temperature at measurement (°C, −50 to 100); needed with
        ``alpha_half_width``.
    u_temperature : float
        u_T (K, ≥ 0): standard uncertainty of the part's temperature.
    form : float
        F (mm, ≥ 0): the parts' form deviation, peak to valley.

    Raises
    ------
    InputError
        A non-finite or out-of-range input, or an input that needs another one missing
        (each named by its option).
    """

    length: float | None = None
    alpha: float = 0.0
    alpha_half_width: float = 0.0
    temperature: float | None = None
    u_temperature: float = 0.0
    form: float = 0.0

    def __post_init__(self) -> None:
        checked = {
            "length": checked_number(self.length, "--length"),
            "alpha": checked_number(self.alpha, "--alpha"),
            "alpha_half_width": checked_number(
                self.alpha_half_width, "--alpha-half-width", minimum=0
            ),
            "temperature": checked_number(self.temperature, "--temperature"),
            "u_temperature": checked_number(self.u_temperature, "--u-temperature", minimum=0),
            "form": checked_number(self.form, "--form", minimum=0),
        }
        for name, value in checked.items():
            object.__setattr__(self, name, value)
        if self.length is not None and self.length <= 0:
            raise InputError(f"--length: must be > 0 mm, got {self.length:g}")
        if self.temperature is not None:
            check_temperatures(self.temperature, "--temperature")
        if self.alpha_half_width > 0 and self.temperature is None:
            raise InputError("--temperature: needed with --alpha-half-width (u_w)")
        if self.u_temperature > 0 and self.alpha == 0:
            raise InputError("--alpha: needed with --u-temperature (u_w)")

    @property
    def u_alpha(self) -> float:
        """u_α = a_α/√3 (1/K; rectangular, JCGM 100:2008, 4.3.7)."""
        return self.alpha_half_width / math.sqrt(3.0)

    def components(self) -> dict[str, float]:
        """The four terms of u_w (mm), whose root-sum-square is :meth:`u`.

        Returns
        -------
        dict
            ``alpha`` L·|T − 20|·u_α, ``temperature`` L·|α|·u_T, ``product`` L·u_α·u_T,
            ``form`` F/(2√3).

        Raises
        ------
        InputError
            :attr:`length` is not given.
        """
        if self.length is None:
            raise InputError("--length: the length L of u_w is not given")
        L = self.length
        dt = 0.0 if self.temperature is None else self.temperature - REFERENCE_TEMPERATURE
        return {
            "alpha": L * abs(dt) * self.u_alpha,
            "temperature": L * abs(self.alpha) * self.u_temperature,
            "product": L * self.u_alpha * self.u_temperature,
            "form": self.form / (2.0 * math.sqrt(3.0)),
        }

    def u(self) -> float:
        """u_w (mm) by :data:`FORMULA`.

        Examples
        --------
        Steel, α = 11.5 µm/(m·K) ± 1 µm/(m·K), a 100 mm size at 23 °C ± 0.5 K:

        >>> w = WorkpieceVariation(100.0, 11.5e-6, 1e-6, 23.0, 0.5)
        >>> round(w.u() * 1e3, 4)  # µm: √(0.1732² + 0.575² + 0.0289²)
        0.6012
        """
        return math.sqrt(sum(c * c for c in self.components().values()))

    def to_dict(self) -> dict:
        """JSON form: the inputs (internal units), the components in mm and µm, u_w, and the
        formula."""
        parts = self.components()
        return {
            "formula": FORMULA,
            "length": self.length,
            "alpha": self.alpha,
            "alpha_half_width": self.alpha_half_width,
            "u_alpha": self.u_alpha,
            "temperature": self.temperature,
            "u_temperature": self.u_temperature,
            "form": self.form,
            "components": parts,
            "u_w": self.u(),
            "um": {
                **{name: float(from_internal(v, "µm")) for name, v in parts.items()},
                "u_w": float(from_internal(self.u(), "µm")),
            },
        }

    @classmethod
    def from_dict(cls, doc: dict) -> WorkpieceVariation:
        """Read :meth:`to_dict`'s inputs back."""
        return cls(
            length=doc["length"],
            alpha=doc["alpha"],
            alpha_half_width=doc["alpha_half_width"],
            temperature=doc["temperature"],
            u_temperature=doc["u_temperature"],
            form=doc["form"],
        )
