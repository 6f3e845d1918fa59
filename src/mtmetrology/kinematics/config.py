"""Machine-definition files (YAML), validated with pydantic.

A machine file states the topology, the nominal geometry of every axis, the tool
(stylus-centre) vector, the probe, and one or more named error models::

    kind: machine
    version: 1
    name: five-axis-wcbxfzyst
    topology: WCBXFZYST
    axes:
      X: {direction: +X, sign: -1, travel_mm: [-220, 230], resolution_mm: 0.0005}
      B: {direction: +Y, sign: -1, travel_deg: [-90, 90]}
      Z: {direction: +Z, travel_mm: [-110, 220], offset_mm: [0, 0, 150]}
    tool_mm: [0, 0, -150]
    probe: {tip_radius_mm: 2.9625}
    error_models:
      "13":
        basis: monomial
        parameters: [E_A0B, E_C0B, E_X0C, E_XX1]
      "84":
        motions: {E_XX: [1, 2, 3], E_AX: [0, 1, 2, 3]}
        parameters: [E_BBb, E_CCb]
    default_model: "13"

Every field carrying a quantity states its unit in its name (``_mm``, ``_deg``).
Validation errors name the file and the field path (``axes.B.travel_deg``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Literal

from pydantic import Field, Strict, ValidationError, field_validator

from mtmetrology.errors import InputError
from mtmetrology.io.documents import load_document
from mtmetrology.io.schema import (
    Integer,
    Number,
    Sign,
    StrictModel,
    Text,
    Version,
    describe_validation_error,
)
from mtmetrology.kinematics.parameters import MAX_DEGREE

__all__ = [
    "AxisSpec",
    "ErrorModelSpec",
    "MachineFileError",
    "MachineSpec",
    "load_machine_spec",
    "parse_machine_spec",
]


class MachineFileError(InputError):
    """A machine definition that cannot be used; the message names file and field."""


_Vec3 = tuple[Number, Number, Number]
_Range = tuple[Number, Number]
_Strict = StrictModel  # unknown keys, non-finite numbers, booleans as numbers refused


class AxisSpec(_Strict):
    """One axis. Linear axes use ``*_mm`` fields, rotary axes ``*_deg`` fields."""

    direction: Text | _Vec3 | None = None
    sign: Sign | None = None
    travel_mm: _Range | None = None
    travel_deg: _Range | None = None
    resolution_mm: Number | None = Field(default=None, gt=0)
    resolution_deg: Number | None = Field(default=None, gt=0)
    offset_mm: _Vec3 = (0.0, 0.0, 0.0)
    basis: Literal["monomial", "legendre", "chebyshev"] | None = None

    @field_validator("travel_mm", "travel_deg")
    @classmethod
    def _ordered(cls, v):
        if v is not None and not v[0] < v[1]:
            raise ValueError(f"travel must be [min, max] with min < max, got {list(v)}")
        return v

    @field_validator("direction")
    @classmethod
    def _direction(cls, v):
        if isinstance(v, str):
            s = v.strip().upper()
            if s.lstrip("+-") not in ("X", "Y", "Z"):
                raise ValueError(f"direction {v!r}: use +X, -Y, Z ... or a 3-vector")
        elif v is not None and sum(c * c for c in v) == 0:
            raise ValueError("direction vector must not be zero")
        return v


class ErrorModelSpec(_Strict):
    """A named error model: parameter names, error-motion degrees, basis."""

    description: Text = ""
    basis: Literal["monomial", "legendre", "chebyshev"] = "monomial"
    normalise: Annotated[bool, Strict()] | None = None
    parameters: list[Text] = Field(default_factory=list)
    motions: dict[Text, list[Annotated[Integer, Field(le=MAX_DEGREE)]]] = Field(
        default_factory=dict
    )

    @field_validator("motions")
    @classmethod
    def _motions(cls, v):
        for key, degrees in v.items():
            k = key.strip()
            if not (len(k) == 4 and k.startswith("E_") and k[2] in "XYZABC"):
                raise ValueError(
                    f"motion function {key!r}: expected an ISO 230-1 error motion such as "
                    "'E_XX' (error direction, moving axis)"
                )
            if any(d < 0 for d in degrees):
                raise ValueError(f"motion {key}: degrees must be >= 0, got {degrees}")
        return v


class ProbeSpec(_Strict):
    tip_radius_mm: Number = Field(default=0.0, ge=0)


class MachineSpec(_Strict):
    kind: Literal["machine"] = "machine"
    version: Version = 1
    name: Text
    description: Text = ""
    topology: Text
    axes: dict[str, AxisSpec] = Field(default_factory=dict)
    workpiece_offset_mm: _Vec3 = (0.0, 0.0, 0.0)
    tool_mm: _Vec3 = (0.0, 0.0, 0.0)
    probe: ProbeSpec = Field(default_factory=ProbeSpec)
    error_models: dict[str, ErrorModelSpec] = Field(default_factory=dict)
    default_model: Text | None = None


def parse_machine_spec(data: object, source: str = "<machine>") -> MachineSpec:
    """Validate a machine definition already parsed from YAML/JSON."""
    if not isinstance(data, dict):
        raise MachineFileError(f"{source}: a machine definition must be a mapping")
    try:
        return MachineSpec.model_validate(data)
    except ValidationError as err:
        raise MachineFileError(
            describe_validation_error(source, "machine definition", err)
        ) from None


def load_machine_spec(path: str | Path) -> MachineSpec:
    """Read and validate a machine YAML file."""
    try:
        data = load_document(path, "machine definition")
    except InputError as err:
        raise MachineFileError(str(err)) from None
    return parse_machine_spec(data, str(path))
