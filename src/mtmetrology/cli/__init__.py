"""The ``mtm`` command line."""

from __future__ import annotations

import typer

from mtmetrology.cli import fit, machine, predict, repeatability, task, uncertainty

app = typer.Typer(
    name="mtm",
    help="mtmetrology: machine-tool and CMM metrology from the command line.",
    no_args_is_help=True,
    add_completion=False,
)
app.add_typer(machine.app, name="machine")
app.add_typer(uncertainty.app, name="uncertainty")
app.add_typer(repeatability.app, name="repeatability")
app.add_typer(task.app, name="task")
app.command("fit")(fit.fit)
app.command("predict")(predict.predict)

__all__ = ["app"]
