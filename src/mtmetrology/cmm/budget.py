"""Uncertainty budget of a ball-plate length calibrated on a CMM (Salacheep 2016, §3.8).

Model (eq. 3.14, with the thermal correction to 20 °C written out)::

    l_x = l_obs + δl_vm + δl_is + δl_RP + δl_n − δl_Ax
          − l_0 [α Δt_x + α δt_m + α δt_d + Δt_x δα]
    δl_n = −l_0 (n(t, p, R) − n̂)/n̂,   t = t̂ + δt_cal + δt_read, p, R likewise

with the refractive index of air n from the modified Edlén equation (eq. 3.19, the vacuum
wavenumber σ in µm⁻¹ — the source writes mm⁻¹)::

    (n − 1)·10⁸ = [8342.54 + 2406147/(130 − σ²) + 15998/(38.9 − σ²)] (p/96095.43)
                  · [1 + 10⁻⁸ (0.601 − 0.00972 t) p] / (1 + 0.0036610 t)
                  − R (8.753 + 0.036588 t²)(0.037345 − 0.000401 σ²)

(p in Pa, t in °C, R in %RH).  The 15 items of the source's table (digest of Salacheep
2016, §2.17 b): 1 observed length (Type A, s/√n with the largest observed s),
2 verification measurement (rectangular, ±x), 3 indication resolution (±x/2), 4 probing
reproducibility (±x), 5 refractive index (through items 6–11), 6/7 hygrometer certificate
(k = 2) and resolution, 8/9 barometer, 10/11 air thermometer, 12 misalignment (cosine
error ``L(1 − cos θ)``, θ = asin(e/L), rectangular ±L(1 − cos θ) as the source), 13 part
thermometer (k = 2), 14 temperature distribution (±x), 15 CTE (±x).  The source's
mislabelled item 15 is taken as ``Δt_x·u(δα)``; its literal "1 %" of item 7 is the user's
resolution.  The sensitivities are those of the model (the source's a1…a5 are not given),
propagated by the project's GUF (JCGM 100:2008, §5).

References
----------
Salacheep, P. (2016). *Error Compensation and Uncertainty Evaluation of CMMs Based on
Kinematic Error Models and Gaussian Processes*. MPhil thesis, Brunel University London,
§3.8, eqs 3.14–3.29.
Edlén, B. (1966). The refractive index of air. *Metrologia* 2(2), 71–80.
JCGM 100:2008, §5.1.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from mtmetrology.cmm.notebook import CMMNotebookRepr
from mtmetrology.cmm.statement import CMMStatement, SpecificationSpec
from mtmetrology.errors import InputError
from mtmetrology.io.documents import load_document
from mtmetrology.io.files import InputFileError
from mtmetrology.io.schema import describe_validation_error
from mtmetrology.uncertainty import GUFResult, InputQuantity, InputSet, Normal, Rectangular, guf
from mtmetrology.uncertainty.coverage import DEFAULT_P
from mtmetrology.units import from_internal, to_internal

__all__ = [
    "BallPlateLengthBudget",
    "BudgetSpec",
    "ballplate_budget",
    "ballplate_budget_file",
    "cmm_statement",
    "cosine_error",
    "edlen_refractivity",
    "load_budget",
]

REFERENCE_TEMPERATURE_C = 20.0


def edlen_refractivity(t_c, p_pa, rh_percent, wavenumber_per_um=1 / 0.63299):
    """``n − 1`` of air by the modified Edlén equation (Salacheep 2016, eq. 3.19).

    Parameters
    ----------
    t_c : array_like
        Air temperature, °C.
    p_pa : array_like
        Pressure, Pa.
    rh_percent : array_like
        Relative humidity, %.
    wavenumber_per_um : float
        Vacuum wavenumber σ = 1/λ_vac, µm⁻¹ (default: He–Ne, 632.99 nm).

    Returns
    -------
    ndarray
        n − 1 (dimensionless).

    Examples
    --------
    >>> round(float(edlen_refractivity(20.0, 101325.0, 50.0)) * 1e4, 5)
    2.71374
    """
    s2 = wavenumber_per_um**2
    t = np.asarray(t_c, dtype=float)
    p = np.asarray(p_pa, dtype=float)
    dry = (8342.54 + 2406147.0 / (130.0 - s2) + 15998.0 / (38.9 - s2)) * (p / 96095.43)
    dry = dry * (1.0 + 1e-8 * (0.601 - 0.00972 * t) * p) / (1.0 + 0.0036610 * t)
    water = np.asarray(rh_percent) * (8.753 + 0.036588 * t**2) * (0.037345 - 0.000401 * s2)
    return (dry - water) * 1e-8


def cosine_error(length, misalignment):
    """``L (1 − cos θ)`` with ``θ = asin(e/L)`` (Salacheep 2016, eq. 3.26), same unit as L.

    Examples
    --------
    >>> f"{cosine_error(620.0, 0.010):.3g}"
    '8.06e-08'
    """
    theta = np.arcsin(misalignment / length)
    return length * 2.0 * np.sin(theta / 2.0) ** 2  # 1 − cos θ without cancellation


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class Observed(_Strict):
    value_mm: float = Field(gt=0)
    s_um: float = Field(ge=0)
    n: int = Field(ge=1)


class Air(_Strict):
    temperature_C: float = Field(ge=-10, le=50)
    pressure_Pa: float = Field(gt=50000, lt=120000)
    humidity_percent: float = Field(ge=0, le=100)
    wavelength_um: float = Field(default=0.63299, gt=0.2, lt=2.0)


class BudgetSpec(_Strict):
    """User inputs of the ball-plate budget (every field states its unit)."""

    kind: Literal["ballplate-budget"]
    length_mm: float = Field(gt=0)
    observed: Observed
    verification_um: float = Field(ge=0)
    indication_resolution_um: float = Field(ge=0)
    probe_reproducibility_um: float = Field(ge=0)
    air: Air
    hygrometer_U_percent: float = Field(ge=0)
    humidity_resolution_percent: float = Field(ge=0)
    barometer_U_Pa: float = Field(ge=0)
    pressure_resolution_Pa: float = Field(ge=0)
    air_thermometer_U_K: float = Field(ge=0)
    air_thermometer_resolution_K: float = Field(ge=0)
    misalignment_um: float = Field(ge=0)
    part_temperature_C: float = Field(ge=-10, le=50)
    part_thermometer_U_K: float = Field(ge=0)
    temperature_spread_K: float = Field(ge=0)
    cte_per_K: float = Field(ge=0)
    cte_halfwidth_per_K: float = Field(ge=0)
    specification: SpecificationSpec | None = None


def load_budget(path: str | Path) -> BudgetSpec:
    """Read and validate a budget input file."""
    doc = load_document(path, "ball-plate budget")
    try:
        return BudgetSpec.model_validate(doc)
    except ValidationError as err:
        msg = describe_validation_error(str(path), "ball-plate budget", err)
        raise InputFileError(msg.replace("\n ", ";")) from None


def _rect(name, half, unit):
    return InputQuantity(name, Rectangular(-half, half) if half > 0 else Normal(0.0, 0.0), unit)


def ballplate_budget(spec: BudgetSpec, p: float = DEFAULT_P):
    """GUF of the calibrated length with its 15-item budget.

    Parameters
    ----------
    spec : BudgetSpec
    p : float
        Coverage probability of U (default 2 Φ(2) − 1: k = 2 for a normal output,
        :mod:`mtmetrology.uncertainty.coverage`).

    Returns
    -------
    mtmetrology.uncertainty.GUFResult
        One output ``l_x`` (mm); ``to_dict()`` gives the project's uncertainty-result form
        and the budget rows (input, u, sensitivity, contribution, share).
    """
    um = to_internal(1.0, "µm")
    l0 = spec.length_mm
    air = spec.air
    sigma = 1.0 / air.wavelength_um
    n_hat = 1.0 + edlen_refractivity(
        air.temperature_C, air.pressure_Pa, air.humidity_percent, sigma
    )
    dt = spec.part_temperature_C - REFERENCE_TEMPERATURE_C
    alpha = spec.cte_per_K
    a_cos = cosine_error(l0, spec.misalignment_um * um)
    obs = spec.observed
    q = [
        InputQuantity("l_obs", Normal(obs.value_mm, obs.s_um * um / np.sqrt(obs.n)), "mm"),
        _rect("dl_vm", spec.verification_um * um, "mm"),
        _rect("dl_is", spec.indication_resolution_um * um / 2, "mm"),
        _rect("dl_RP", spec.probe_reproducibility_um * um, "mm"),
        InputQuantity("R_cal", Normal(air.humidity_percent, spec.hygrometer_U_percent / 2), "%"),
        _rect("R_read", spec.humidity_resolution_percent / 2, "%"),
        InputQuantity("p_cal", Normal(air.pressure_Pa, spec.barometer_U_Pa / 2), "Pa"),
        _rect("p_read", spec.pressure_resolution_Pa / 2, "Pa"),
        InputQuantity("t_cal", Normal(air.temperature_C, spec.air_thermometer_U_K / 2), "°C"),
        _rect("t_read", spec.air_thermometer_resolution_K / 2, "K"),
        _rect("dl_Ax", a_cos, "mm"),
        InputQuantity("dt_m", Normal(0.0, spec.part_thermometer_U_K / 2), "K"),
        _rect("dt_d", spec.temperature_spread_K, "K"),
        _rect("d_alpha", spec.cte_halfwidth_per_K, "1/K"),
    ]

    def model(x):
        x = np.asarray(x, dtype=float)
        n = 1.0 + edlen_refractivity(
            x[..., 8] + x[..., 9], x[..., 6] + x[..., 7], x[..., 4] + x[..., 5], sigma
        )
        dl_n = -l0 * (n - n_hat) / n_hat
        thermal = l0 * (alpha * dt + alpha * x[..., 11] + alpha * x[..., 12] + dt * x[..., 13])
        return x[..., 0] + x[..., 1] + x[..., 2] + x[..., 3] + dl_n - x[..., 10] - thermal

    return guf(model, InputSet(q), output_names=["l_x"], output_units=["mm"], p=p)


def cmm_statement(spec) -> CMMStatement:
    """The statement of :mod:`~mtmetrology.cmm.statement` for a budget.

    Parameters
    ----------
    spec : BudgetSpec
        With its ``specification`` section; the length, part temperature, CTE and its
        half-width, thermometer U, temperature spread and misalignment are the budget's.

    Returns
    -------
    CMMStatement

    Raises
    ------
    InputError
        The budget has no ``specification`` section.

    """
    s = spec.specification
    if s is None:
        raise InputError("specification: the budget has no specification section")
    length = spec.length_mm
    u_plate = s.plate_U.expanded(length)
    u_alpha = spec.cte_halfwidth_per_K / np.sqrt(3.0)
    u_t = np.hypot(spec.part_thermometer_U_K / 2.0, spec.temperature_spread_K / np.sqrt(3.0))
    dt = abs(spec.part_temperature_C - REFERENCE_TEMPERATURE_C)
    align = cosine_error(length, to_internal(spec.misalignment_um, "µm")) / np.sqrt(3.0)
    items = {
        "cal": u_plate / 2.0,
        "alpha": float(from_internal(length * dt * u_alpha, "µm")),
        "t": float(from_internal(length * spec.cte_per_K * u_t, "µm")),
        "align": float(from_internal(align, "µm")),
        "fixt": s.fixturing_u_um,
    }
    return CMMStatement(
        length_mm=length,
        U_cmm_um=s.cmm_U.expanded(length),
        U_plate_um=u_plate,
        mpe_um=s.mpe_a_um + length / s.mpe_length_divisor,
        u_P_um=float(np.hypot(s.sphere_form_um / 2.0, s.sphere_form_u_um)),
        u_E_um=float(np.sqrt(sum(v**2 for v in items.values()))),
        E_items_um=items,
    )


@dataclass(frozen=True, eq=False)
class BallPlateLengthBudget(CMMNotebookRepr):
    """The ``mtm cmm budget`` result: a calibrated length's budget and, when the inputs
    carry a specification, the CMM statement at that length.

    Attributes
    ----------
    guf : GUFResult
        :func:`ballplate_budget` of the inputs (one output ``l_x``, mm).
    statement : CMMStatement or None
        :func:`cmm_statement` (U, MPE, u(P), u(E) of eqs 3.10–3.13), None without a
        ``specification`` section.
    """

    guf: GUFResult
    statement: CMMStatement | None = None

    def to_dict(self) -> dict:
        """``ballplate-budget-result`` document: the GUF result's fields and ``statement``."""
        doc = {"kind": "ballplate-budget-result", "version": 1, **self.guf.to_dict()}
        if self.statement is not None:
            doc["statement"] = self.statement.to_dict()
        return doc


def ballplate_budget_file(path: str | Path, p: float = DEFAULT_P) -> BallPlateLengthBudget:
    """The budget (and statement) of a ``ballplate-budget`` inputs file (what ``mtm cmm
    budget`` computes), U at coverage probability ``p``; errors name the file and the
    field."""
    spec = load_budget(path)
    statement = cmm_statement(spec) if spec.specification is not None else None
    return BallPlateLengthBudget(ballplate_budget(spec, p), statement)
