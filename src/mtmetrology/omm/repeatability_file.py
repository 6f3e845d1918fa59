"""Strict reading of ``repeatability-model`` documents (``mtm repeatability fit -o R.json``).

The document is validated (pydantic, unknown keys and non-finite numbers refused) and
checked against the model's structure: the seven factors in order with their units and
a non-empty range, the nine outputs with 22 (eq. 4-1) or 36 (eq. 4-2) coefficients.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, ValidationError

from mtmetrology.errors import InputError
from mtmetrology.io.documents import load_document
from mtmetrology.io.schema import describe_validation_error
from mtmetrology.omm.repeatability import (
    COVARIANCE_OUTPUTS,
    FACTOR_UNITS,
    FACTORS,
    STD_OUTPUTS,
)
from mtmetrology.omm.repeatability_model import (
    COVARIANCE_DEGREES,
    STD_DEGREES,
    OutputFit,
    RepeatabilityModel,
)
from mtmetrology.units import to_internal

__all__ = ["load_repeatability_model", "repeatability_model_from_document"]

_STRICT = ConfigDict(extra="forbid", allow_inf_nan=False)


class _Factor(BaseModel):
    model_config = _STRICT
    name: str
    unit: str
    low: float
    high: float


class _Output(BaseModel):
    model_config = _STRICT
    name: str
    unit: str
    equation: Literal["4-1", "4-2"]
    coefficients: list[float]
    u: list[float]
    r_squared: float
    validation_max_relative_error: float | None
    validation_max_abs_error: float | None
    validation_rms_relative_error: float | None = None
    validation_flagged: bool | None = None


class _Document(BaseModel):
    model_config = _STRICT
    kind: Literal["repeatability-model"]
    version: Literal[1]
    factors: list[_Factor]
    normalisation: str
    n_fit: int
    n_validation: int
    validation_warning: float | None = None
    outputs: list[_Output]
    source: str | None = None
    statistics: dict | None = None
    windows: dict | None = None
    resolution_warnings: list[str] = []


def _n_coefficients(degrees: tuple[int, ...]) -> int:
    return 1 + sum(degrees)


def repeatability_model_from_document(document: object, source: str) -> RepeatabilityModel:
    """Build a :class:`RepeatabilityModel` from a parsed document.

    Raises
    ------
    InputError
        Schema errors, factors or outputs not those of eqs. 4-1/4-2, a wrong number of
        coefficients or an empty factor range; the message names ``source`` and the field.
    """
    try:
        doc = _Document.model_validate(document)
    except ValidationError as err:
        raise InputError(
            describe_validation_error(source, "repeatability model", err).replace("\n  ", "; ")
        ) from None
    if [(f.name, f.unit) for f in doc.factors] != list(zip(FACTORS, FACTOR_UNITS, strict=True)):
        raise InputError(f"{source}: factors must be {list(FACTORS)} in units {list(FACTOR_UNITS)}")
    low = np.array([to_internal(f.low, f.unit) for f in doc.factors])
    high = np.array([to_internal(f.high, f.unit) for f in doc.factors])
    empty = np.flatnonzero(~(high > low))
    if empty.size:
        raise InputError(f"{source}: factors.{FACTORS[empty[0]]}: high must exceed low")
    names = STD_OUTPUTS + COVARIANCE_OUTPUTS
    if [o.name for o in doc.outputs] != list(names):
        raise InputError(f"{source}: outputs must be {list(names)} in this order")
    fits = []
    for o in doc.outputs:
        is_std = o.name in STD_OUTPUTS
        degrees = STD_DEGREES if is_std else COVARIANCE_DEGREES
        unit, size = ("µm" if is_std else "µm²"), _n_coefficients(degrees)
        if o.unit != unit or len(o.coefficients) != size or len(o.u) != size:
            raise InputError(
                f"{source}: outputs.{o.name}: expected {size} coefficients and u in {unit}"
            )
        scale = to_internal(1.0, "µm") if is_std else to_internal(1.0, "µm") ** 2
        fits.append(
            OutputFit(
                o.name,
                np.array(o.coefficients) * scale,
                np.array(o.u) * scale,
                o.r_squared,
                o.validation_max_relative_error,
                None if o.validation_max_abs_error is None else o.validation_max_abs_error * scale,
                o.validation_rms_relative_error,
            )
        )
    return RepeatabilityModel(low, high, tuple(fits), doc.n_fit, doc.n_validation)


def load_repeatability_model(path: str | Path) -> RepeatabilityModel:
    """Read a ``repeatability-model`` JSON/YAML file strictly (see the module notes)."""
    document = load_document(path, "repeatability model")
    return repeatability_model_from_document(document, str(path))
