"""``--history`` of the calibrate commands: record the result in the calibration history in
the same step (:func:`mtmetrology.history.add_result`, database ``$MTMETROLOGY_DB`` or the
default file)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from mtmetrology.kinematics.machine import Machine

__all__ = ["HistoryOption", "record_in_history"]

HistoryOption = Annotated[
    bool,
    typer.Option(
        "--history",
        help="Also record the result in the calibration history ($MTMETROLOGY_DB, else the "
        "default database; see mtm history).",
    ),
]


def record_in_history(document: dict, machine: Machine, command: str, inputs: list[Path]) -> None:
    """Record ``document`` (before any output is written: a refusal leaves nothing)."""
    from mtmetrology.history import add_result, open_history

    record = add_result(
        open_history(),
        document,
        machine,
        source=command,
        input_files=tuple(p for p in inputs if Path(p).is_file()),
    )
    typer.echo(f"recorded calibration run {record.id} in the history", err=True)
