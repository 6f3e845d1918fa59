"""``mtm uncertainty``: measurement-model files through GUF and Monte Carlo."""

import typer

app = typer.Typer(help="Evaluate measurement uncertainty (GUF, Monte Carlo).", no_args_is_help=True)
