"""Strict schema building blocks for user files, and one-line messages for their errors.

A calibration result moves a machine, so a file value is taken only as what it says:
``true`` is not 1, ``"12.5"`` is not a number, NaN and infinities are not quantities,
unknown keys are mistakes, and a ``version`` this code does not know is refused.  The
types below carry those rules for every pydantic schema of the project (machine files,
artefacts, measurement models):

>>> class Probe(StrictModel):
...     version: Version = 1
...     tip_radius_mm: Number = 0.0
>>> Probe.model_validate({"tip_radius_mm": 2})
Probe(version=1, tip_radius_mm=2.0)
>>> from pydantic import ValidationError
>>> for bad in ({"tip_radius_mm": True}, {"tip_radius_mm": ".nan"}, {"version": 99}):
...     try:
...         Probe.model_validate(bad)
...     except ValidationError as err:
...         print(describe_validation_error("probe.yaml", "probe", err))
probe.yaml: invalid probe: tip_radius_mm: Input should be a valid number
probe.yaml: invalid probe: tip_radius_mm: Input should be a valid number
probe.yaml: invalid probe: version: version 99 is not supported (this mtmetrology reads version 1)
"""

from __future__ import annotations

from typing import Annotated

from pydantic import (
    AfterValidator,
    BaseModel,
    ConfigDict,
    Strict,
    ValidationError,
    model_validator,
)

__all__ = [
    "Integer",
    "Number",
    "Sign",
    "StrictModel",
    "Text",
    "Version",
    "describe_validation_error",
]


def _version_one(v: int) -> int:
    if v != 1:
        raise ValueError(f"version {v} is not supported (this mtmetrology reads version 1)")
    return v


def _sign(v: int) -> int:
    if v not in (-1, 1):
        raise ValueError(f"sign must be 1 or -1, got {v}")
    return v


#: A real number written as a number (an integer is fine; a boolean or a string is not).
Number = Annotated[float, Strict()]
#: An integer written as one (not ``true``, not ``2.0``, not ``"2"``).
Integer = Annotated[int, Strict()]
#: Text written as text.
Text = Annotated[str, Strict()]
#: +1 or -1, written as an integer.
Sign = Annotated[int, Strict(), AfterValidator(_sign)]
#: The file-format version: 1 is the only one.
Version = Annotated[int, Strict(), AfterValidator(_version_one)]


class StrictModel(BaseModel):
    """Base of file schemas: unknown keys, empty values (``key:`` or ``key: null``, which
    would silently mean "the default") and non-finite floats refused; frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    @model_validator(mode="before")
    @classmethod
    def _no_empty_values(cls, data):
        if isinstance(data, dict):
            empty = next((k for k, v in data.items() if v is None), None)
            if empty is not None:
                raise ValueError(f"{empty}: empty value; give a value or leave the key out")
        return data


def describe_validation_error(source: str, what: str, err: ValidationError) -> str:
    """One line naming the file, the field path and the problem (and how many more).

    Parameters
    ----------
    source : str
        The file (or other origin) being read.
    what : str
        What the file should have been, e.g. ``"machine definition"``.
    err : pydantic.ValidationError

    Returns
    -------
    str
        ``"machine.yaml: invalid machine definition: axes.B.travel_deg: ..."``, with
        ``" (and 2 more: tool_mm, probe)"`` when several fields are wrong.
    """
    problems = err.errors()
    first = problems[0]
    path = ".".join(str(p) for p in first["loc"]) or "(top level)"
    message = " ".join(str(first["msg"]).removeprefix("Value error, ").split())
    line = f"{source}: invalid {what}: {path}: {message}"
    if len(problems) > 1:
        others = [".".join(str(p) for p in e["loc"]) or "(top level)" for e in problems[1:4]]
        more = ", ".join(others) + (", ..." if len(problems) > 4 else "")
        line += f" (and {len(problems) - 1} more: {more})"
    return line
