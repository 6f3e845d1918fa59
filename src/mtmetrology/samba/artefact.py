"""SAMBA artefact files (ARCHITECTURE.md, "Files users bring and get")::

kind: samba-artefact
version: 1
balls:
  - {id: "1", diameter_mm: 12.7}
  - {id: SB1, diameter_mm: 12.7}
  - {id: SB2, diameter_mm: 12.7}
scale_bar: {ends: [SB1, SB2], length_mm: 305.2105, u_mm: 0.0012}
stylus_tip_diameter_mm: 5.925
tools:                          # optional: several styli, the records' tool column
  - {id: long, vector_mm: [0, 0, -150]}
  - {id: short, vector_mm: [0, 0, -100]}
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from pydantic import Field, ValidationError, model_validator

from mtmetrology.identification.observations import ScaleBar
from mtmetrology.io.documents import load_document
from mtmetrology.io.files import InputFileError
from mtmetrology.io.schema import Number, StrictModel, Text, Version, describe_validation_error

__all__ = ["SambaArtefact", "load_artefact"]


_Strict = StrictModel  # unknown keys, non-finite numbers, booleans as numbers refused


class BallSpec(_Strict):
    id: Text
    diameter_mm: Number = Field(gt=0)


class ScaleBarSpec(_Strict):
    ends: tuple[Text, Text]
    length_mm: Number = Field(gt=0)
    u_mm: Number = Field(gt=0)


class ToolSpec(_Strict):
    """A tool (stylus) of a test with several: its id (the records' ``tool`` column) and
    its nominal vector from the spindle nose to the stylus centre, mm."""

    id: Text
    vector_mm: tuple[Number, Number, Number]


class SambaArtefact(_Strict):
    """A SAMBA artefact: master balls, scale-bar balls and the calibrated bar length."""

    kind: Literal["samba-artefact"] = "samba-artefact"
    version: Version = 1
    balls: list[BallSpec] = Field(min_length=1)
    scale_bar: ScaleBarSpec | None = None
    stylus_tip_diameter_mm: Number | None = Field(default=None, gt=0)
    tools: list[ToolSpec] | None = Field(default=None, min_length=1)

    @model_validator(mode="after")
    def _ends_are_balls(self):
        ids = [b.id for b in self.balls]
        dup = sorted({i for i in ids if ids.count(i) > 1})
        if dup:
            raise ValueError(f"ball id(s) listed twice: {', '.join(dup)}")
        if self.scale_bar is not None:
            for end in self.scale_bar.ends:
                if end not in ids:
                    raise ValueError(f"scale_bar end {end!r} is not one of the balls")
        tools = [t.id for t in self.tools or []]
        twice = sorted({t for t in tools if tools.count(t) > 1})
        if twice:
            raise ValueError(f"tool id(s) listed twice: {', '.join(twice)}")
        return self

    def stylus_unknowns(self, names) -> dict:
        """``tools``/``tool_index`` of an identification whose indications name their
        stylus (``names``, one per indication): the listed tools that are used, in the
        file's order, and each indication's index into them."""
        import numpy as np

        used = [t for t in self.tools or [] if t.id in set(names)]
        ids = [t.id for t in used]
        return {
            "tools": np.array([t.vector_mm for t in used], dtype=float),
            "tool_index": np.array([ids.index(t) for t in names]),
        }

    def scale_bars(self) -> list[ScaleBar]:
        if self.scale_bar is None:
            return []
        s = self.scale_bar
        return [ScaleBar(tuple(s.ends), s.length_mm, s.u_mm)]


def load_artefact(path: str | Path) -> SambaArtefact:
    """Read and validate a SAMBA artefact YAML file; errors name the file and field."""
    p = Path(path)
    data = load_document(p, "SAMBA artefact")
    try:
        return SambaArtefact.model_validate(data)
    except ValidationError as err:
        raise InputFileError(describe_validation_error(str(p), "SAMBA artefact", err)) from None
