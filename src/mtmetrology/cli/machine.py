"""``mtm machine``: presets, machine files and identifiability."""

import typer

app = typer.Typer(help="Machine definitions: list, show, check, identifiability.", no_args_is_help=True)
