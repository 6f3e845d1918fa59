"""The ``mtm`` command line.

Exit codes: 0 success, 1 internal error (a bug), 2 input error (also rank deficiency,
non-convergence, resource limits), 3 environment error (file system, scheduler),
130 interrupted (nothing written).  Errors are one line on stderr; ``--debug`` shows the
traceback.
"""

from __future__ import annotations

from typing import Annotated

import typer

from mtmetrology.cli import fit, machine, predict, uncertainty
from mtmetrology.cli._common import MtmGroup

app = typer.Typer(
    name="mtm",
    cls=MtmGroup,
    help="mtmetrology: machine-tool and CMM metrology from the command line.\n\n"
    "Exit codes: 0 success, 1 internal error (a bug), 2 input error (also rank "
    "deficiency, non-convergence, resource limits), 3 environment error (file system, "
    "scheduler), 130 interrupted (nothing written).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


@app.callback()
def _options(
    debug: Annotated[
        bool, typer.Option("--debug", help="Show the traceback of an error (for bug reports).")
    ] = False,
) -> None:
    """mtmetrology: machine-tool and CMM metrology from the command line."""


app.add_typer(machine.app, name="machine")
app.add_typer(uncertainty.app, name="uncertainty")
app.command("fit")(fit.fit)
app.command("predict")(predict.predict)

__all__ = ["app"]
