"""Shared checks of the control writers: which functions a format carries, equal spacing."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.export.model import CompensationModel, ErrorTable

__all__ = ["check_points", "corrections", "select"]


def select(
    model: CompensationModel,
    carries: Callable[[ErrorTable], str | None],
    functions: Sequence[str] | None,
    fmt: str,
) -> list[ErrorTable]:
    """The tables a format carries; a function asked for that it cannot carry is refused.

    ``carries(table)`` returns None when the format can carry the table, or the reason it
    cannot.  Without ``functions`` every table the format can carry is selected.
    """
    if functions:
        out = []
        for name in functions:
            table = model.table(name)
            why = carries(table)
            if why is not None:
                raise InputError(f"{name}: format {fmt} cannot carry it ({why})")
            out.append(table)
        return out
    return [t for t in model.tables if carries(t) is None]


def corrections(model: CompensationModel, table: ErrorTable) -> tuple[np.ndarray, np.ndarray]:
    """Forward and reverse corrections (−E) of a table, whatever the model's flag."""
    s = -model.sign
    return s * table.forward, s * table.reverse


def check_points(fmt: str, function: str, n: int, limit: int, what: str) -> None:
    """Refuse a table with more points than the control accepts."""
    if n > limit:
        raise InputError(
            f"{function}: {n} points; format {fmt} accepts at most {limit} ({what}); "
            "choose a larger pitch or fewer points"
        )
