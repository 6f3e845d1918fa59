"""Measurement-model files: YAML inputs, correlations and output expressions.

A model file looks like::

    kind: measurement-model
    version: 1
    name: GUM H.1 end gauge
    inputs:
      - {name: l_s, value: 50000623.6, u: 25, unit: nm, dof: 18}
      - {name: theta, value: -0.1, unit: °C, distribution: {kind: normal, u: 0.41}}
      - {name: res, unit: nm, distribution: {kind: rectangular, x: 0, a: 5}}
    correlations:
      - {inputs: [l_s, d], r: 0.2}
    outputs:
      - {name: l, unit: nm, expression: "l_s + d - l_s * (alpha_s * dtheta + dalpha * theta)"}

``value`` is the estimate, passed as ``x`` to a distribution parameterised by a
centre (normal, student-t, and the ``x, a`` forms of the bounded ones); ``u``
without ``distribution`` is shorthand for a normal.

Output expressions are compiled by :mod:`mtmetrology.uncertainty.expressions` (a safe
subset of Python parsed with :mod:`ast`; never ``eval``).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from mtmetrology.io import InputFileError
from mtmetrology.io.documents import load_document
from mtmetrology.io.schema import Number, StrictModel, Text, Version, describe_validation_error
from mtmetrology.uncertainty.dimensions import check_output_units
from mtmetrology.uncertainty.distributions import make_distribution
from mtmetrology.uncertainty.expressions import (
    CONSTANTS,
    FUNCTIONS,
    CompiledModel,
    ExpressionError,
    ModelFileError,
    check_identifier,
    compile_expressions,
)
from mtmetrology.uncertainty.inputs import InputQuantity, InputSet
from mtmetrology.units import UnitError, parse_unit

__all__ = [
    "CONSTANTS",
    "FUNCTIONS",
    "CompiledModel",
    "ExpressionError",
    "MeasurementModel",
    "ModelFileError",
    "compile_expressions",
    "load_model",
    "parse_model",
]


# --------------------------------------------------------------------------- file schema


_Strict = StrictModel  # unknown keys, empty values, non-finite numbers refused


class DistributionSpec(BaseModel):
    """``{kind: ..., <parameters>}``; parameters are checked by ``make_distribution``."""

    model_config = ConfigDict(extra="allow", allow_inf_nan=False)
    kind: Text

    @model_validator(mode="after")
    def _numbers(self):
        for key, value in (self.model_extra or {}).items():
            _check_number(value, key)
        return self


def _check_number(value: object, key: str, depth: int = 0) -> None:
    """Distribution parameters are numbers or (nested) lists of them, never ``true`` or
    ``"12.5"`` (finiteness and ranges are checked by ``make_distribution``)."""
    if isinstance(value, list) and depth < 3:
        for v in value:
            _check_number(v, key, depth + 1)
        return
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{key}: {value!r} is not a number")


class InputSpec(_Strict):
    name: Text
    value: Number | None = None
    u: Number | None = Field(default=None, ge=0)
    unit: Text = ""
    distribution: DistributionSpec | None = None
    dof: Number | None = Field(default=None, gt=0, allow_inf_nan=True)


class CorrelationSpec(_Strict):
    inputs: tuple[Text, Text]
    r: Number = Field(ge=-1.0, le=1.0)


class OutputSpec(_Strict):
    name: Text
    expression: Text
    unit: Text | None = None  # when given, checked against the expression's dimension


class ModelSpec(_Strict):
    kind: Literal["measurement-model"] = "measurement-model"
    version: Version = 1
    name: Text = ""
    description: Text = ""
    inputs: list[InputSpec] = Field(min_length=1)
    correlations: list[CorrelationSpec] = Field(default_factory=list)
    outputs: list[OutputSpec] = Field(min_length=1)


@dataclass(frozen=True)
class MeasurementModel:
    """A loaded model file: ``inputs`` for GUF/MCM and the compiled ``model``."""

    name: str
    description: str
    inputs: InputSet
    model: CompiledModel
    source: str

    @property
    def output_names(self) -> list[str]:
        return self.model.output_names

    @property
    def output_units(self) -> list[str]:
        return self.model.output_units or [""] * len(self.model.output_names)


def _centred(params: dict) -> bool:
    return not ({"low", "high", "values", "mean", "x"} & params.keys())


def _build_input(spec: InputSpec, i: int, source: str) -> InputQuantity:
    where = f"{source}: inputs.{i} ({spec.name!r})"
    if spec.distribution is not None and spec.u is not None:
        raise ModelFileError(f"{where}: give either u (normal) or distribution, not both")
    if spec.distribution is None:
        if spec.u is None or spec.value is None:
            raise ModelFileError(f"{where}: give value and u, or a distribution")
        kind, params = "normal", {"x": spec.value, "u": spec.u}
    else:
        params = dict(spec.distribution.model_extra or {})
        kind = spec.distribution.kind
        if spec.value is not None:
            if not _centred(params):
                raise ModelFileError(
                    f"{where}.distribution: value is given and the distribution also has "
                    f"{sorted({'low', 'high', 'values', 'mean', 'x'} & params.keys())}; "
                    "give the centre once"
                )
            params["x"] = spec.value
    try:
        dist = make_distribution(kind, **params)
    except (ValueError, TypeError) as exc:
        raise ModelFileError(f"{where}.distribution: {exc}") from None
    if dist.multivariate:
        raise ModelFileError(f"{where}.distribution: inputs are scalar; {kind!r} is multivariate")
    try:
        return InputQuantity(spec.name, dist, spec.unit, spec.dof)
    except ValueError as exc:
        raise ModelFileError(f"{where}: {exc}") from None


def parse_model(document: Any, source: str = "<model>") -> MeasurementModel:
    """Validate a model document (the parsed YAML mapping) and compile it.

    Raises
    ------
    ModelFileError
        Schema errors (with the field path, e.g. ``inputs.2.dof``), bad
        distributions or units, unknown names in correlations.
    ExpressionError
        An output expression outside the safe subset.
    """
    try:
        spec = ModelSpec.model_validate(document)
    except ValidationError as exc:
        raise ModelFileError(describe_validation_error(source, "model file", exc)) from None
    quantities = [_build_input(s, i, source) for i, s in enumerate(spec.inputs)]
    names = [q.name for q in quantities]
    for n in names:
        check_identifier(n, "input", source)
    if len(set(names)) != len(names):
        raise ModelFileError(f"{source}: duplicate input names in {names}")
    corr = None
    if spec.correlations:
        corr = np.eye(len(names))
        for k, c in enumerate(spec.correlations):
            a, b = c.inputs
            for n in (a, b):
                if n not in names:
                    raise ModelFileError(
                        f"{source}: correlations.{k}: unknown input {n!r}; inputs are {names}"
                    )
            if a == b:
                raise ModelFileError(f"{source}: correlations.{k}: an input with itself")
            i, j = names.index(a), names.index(b)
            corr[i, j] = corr[j, i] = c.r
    try:
        inputs = InputSet(quantities, correlation=corr)
    except ValueError as exc:
        raise ModelFileError(f"{source}: correlations: {exc}") from None
    for k, o in enumerate(spec.outputs):
        try:
            parse_unit(o.unit or "")
        except UnitError as exc:
            raise ModelFileError(f"{source}: outputs.{k} ({o.name!r}): {exc}") from None
    model = CompiledModel(
        names,
        [(o.name, o.expression) for o in spec.outputs],
        [o.unit or "" for o in spec.outputs],
        source,
    )
    check_output_units(model, [s.unit for s in spec.inputs], [o.unit for o in spec.outputs], source)
    return MeasurementModel(spec.name, spec.description, inputs, model, source)


def load_model(path: str | os.PathLike) -> MeasurementModel:
    """Read and compile a YAML measurement-model file.

    Raises
    ------
    ModelFileError
        Missing file, YAML syntax error, or any validation error (see :func:`parse_model`).
    """
    path = Path(path)
    try:
        document = load_document(path, "measurement model")
    except ModelFileError:
        raise
    except InputFileError as exc:
        raise ModelFileError(str(exc)) from None
    if not isinstance(document, dict):
        raise ModelFileError(f"{path}: a model file must be a YAML mapping")
    return parse_model(document, str(path))
