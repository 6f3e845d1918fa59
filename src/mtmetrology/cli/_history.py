"""``--history`` of the calibrate commands: record the result in the calibration history in
the same step (:func:`mtmetrology.history.add_result`, database ``$MTMETROLOGY_DB`` or the
default file)."""

from __future__ import annotations

import re
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from mtmetrology.errors import InputError

if TYPE_CHECKING:
    from mtmetrology.kinematics.machine import Machine

__all__ = ["HISTORY_PARAMS", "HistoryOption", "load_parameters", "record_in_history"]

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
    import getpass

    from mtmetrology.history import add_result, open_history

    record = add_result(
        open_history(),
        document,
        machine,
        source=command,
        input_files=tuple(p for p in inputs if Path(p).is_file()),
        by=f"cli:{getpass.getuser()}",
    )
    typer.echo(f"recorded calibration run {record.id} in the history", err=True)


#: ``--long-term history:MACHINE[@DB]``: the machine's long-term covariance from the history.
HISTORY_PARAMS = "history:"


def load_parameters(params: Path, machine: Machine):
    """The parameter set of ``--long-term``: a file, or ``history:MACHINE@DB`` for
    :func:`mtmetrology.history.long_term_covariance` on the history database ``DB`` (a
    SQLite file or a URL; without ``@DB``: $MTMETROLOGY_DB, else the default file;
    without ``MACHINE``: ``machine``'s name). The database is only read."""
    from mtmetrology.kinematics.parameter_set import ParameterSet

    text = str(params)
    if not text.startswith(HISTORY_PARAMS):
        return ParameterSet.load(params, machine)
    from mtmetrology.history.analysis import long_term_covariance
    from mtmetrology.history.database import open_history

    name, at, db = text[len(HISTORY_PARAMS) :].partition("@")
    # --long-term is a Path option: pathlib made "postgresql://h/db" "postgresql:/h/db"
    db = re.sub(r"^([a-z][a-z0-9+]*):/(?!/)", r"\1://", db)
    if at and not db:
        raise InputError(f"--long-term {text!r}: no database after '@' (history:MACHINE@DB)")
    engine = open_history(db or None, read_only=True)
    return long_term_covariance(engine, name or machine.name)
