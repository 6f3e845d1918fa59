"""The ``mtm`` command line."""

from __future__ import annotations

import typer

from mtmetrology.cli import cmm, demo, fit, machine, predict, uncertainty

app = typer.Typer(
    name="mtm",
    help="mtmetrology: machine-tool and CMM metrology from the command line.",
    no_args_is_help=True,
    add_completion=False,
)
calibrate_app = typer.Typer(help="Identify a machine's errors from artefact records.")
simulate_app = typer.Typer(help="Simulate artefact records of a machine with known errors.")


@calibrate_app.callback()
def _calibrate() -> None:
    """Identify a machine's errors from artefact records."""


@simulate_app.callback()
def _simulate() -> None:
    """Simulate artefact records of a machine with known errors."""


cmm.register(calibrate_app, simulate_app)
app.add_typer(machine.app, name="machine")
app.add_typer(uncertainty.app, name="uncertainty")
app.add_typer(calibrate_app, name="calibrate")
app.add_typer(simulate_app, name="simulate")
app.add_typer(cmm.gp_app, name="gp")
app.command("fit")(fit.fit)
app.command("predict")(predict.predict)
app.command("demo")(demo.demo)

__all__ = ["app"]
