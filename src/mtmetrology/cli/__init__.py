"""The ``mtm`` command line.

Exit codes: 0 success, 1 internal error (a bug), 2 input error (also rank deficiency,
non-convergence, resource limits), 3 environment error (file system, scheduler),
130 interrupted (nothing written).  Errors are one line on stderr; ``--debug`` shows the
traceback.

``app`` is the whole command line.  :func:`build_app` builds it with only the command a
run asks for (``mtm predict ...`` then imports neither the fitting nor the uncertainty
engine: a smaller, faster start on large records).
"""

from __future__ import annotations

import importlib
from typing import Annotated

import typer

from mtmetrology.cli._common import MtmGroup

__all__ = ["COMMANDS", "SHARED_GROUPS", "app", "build_app"]

_HELP = (
    "mtmetrology: machine-tool and CMM metrology from the command line.\n\n"
    "Exit codes: 0 success, 1 internal error (a bug), 2 input error (also rank deficiency, "
    "non-convergence, resource limits), 3 environment error (file system, scheduler), "
    "130 interrupted (nothing written)."
)

#: Command name -> (module, attribute, whether it is a group of subcommands).
COMMANDS = {
    "machine": ("mtmetrology.cli.machine", "app", True),
    "uncertainty": ("mtmetrology.cli.uncertainty", "app", True),
    "fit": ("mtmetrology.cli.fit", "fit", False),
    "predict": ("mtmetrology.cli.predict", "predict", False),
    "gp": ("mtmetrology.cli.cmm", "gp_app", True),
    "design": ("mtmetrology.cli.design", "app", True),
    "verify": ("mtmetrology.cli.verify", "app", True),
    "repeatability": ("mtmetrology.cli.repeatability", "app", True),
    "task": ("mtmetrology.cli.task", "app", True),
    "demo": ("mtmetrology.cli.demo", "demo", False),
    "budget": ("mtmetrology.cli.budget", "app", True),
    "export": ("mtmetrology.cli.export", "export", False),
    "validate": ("mtmetrology.cli.validate", "app", True),
}

#: Groups whose subcommands come from several applications (``mtm calibrate samba``,
#: ``mtm calibrate ballplate``): name -> (help, [(module, Typer app whose commands join)]).
SHARED_GROUPS = {
    "calibrate": (
        "Identify a machine's errors from artefact records.",
        [
            ("mtmetrology.cli.calibrate", "app"),
            ("mtmetrology.cli.cmm", "calibrate_app"),
            ("mtmetrology.cli.long_term", "app"),
            ("mtmetrology.cli.multilateration", "calibrate_app"),
            ("mtmetrology.cli.tracker", "calibrate_app"),
        ],
    ),
    "simulate": (
        "Simulate artefact records of a machine with known errors.",
        [
            ("mtmetrology.cli.simulate", "app"),
            ("mtmetrology.cli.cmm", "simulate_app"),
            ("mtmetrology.cli.multilateration", "simulate_app"),
            ("mtmetrology.cli.tracker", "simulate_app"),
        ],
    ),
}


def _shared_group(name: str) -> typer.Typer:
    help_text, members = SHARED_GROUPS[name]
    group = typer.Typer(help=help_text, no_args_is_help=True)
    # A callback keeps a one-command group a group (``mtm calibrate samba``, not ``mtm
    # calibrate``).
    group.callback()(lambda: None)
    for module, attribute in members:
        member = getattr(importlib.import_module(module), attribute)
        group.registered_commands.extend(member.registered_commands)
    return group


def _options(
    debug: Annotated[
        bool, typer.Option("--debug", help="Show the traceback of an error (for bug reports).")
    ] = False,
) -> None:
    """mtmetrology: machine-tool and CMM metrology from the command line."""


def build_app(only: str | None = None) -> typer.Typer:
    """The ``mtm`` application, with every command or only the one named ``only``."""
    application = typer.Typer(
        name="mtm",
        cls=MtmGroup,
        help=_HELP,
        no_args_is_help=True,
        add_completion=False,
        pretty_exceptions_enable=False,
    )
    application.callback()(_options)
    for name, (module, attribute, group) in COMMANDS.items():
        if only is not None and name != only:
            continue
        target = getattr(importlib.import_module(module), attribute)
        if group:
            application.add_typer(target, name=name)
        else:
            application.command(name)(target)
    for name in SHARED_GROUPS:
        if only is None or name == only:
            application.add_typer(_shared_group(name), name=name)
    return application


def __getattr__(name: str):
    # ``app`` is built on first use, so that importing this package (as ``mtm predict``
    # does) does not import every command's engine.
    if name == "app":
        globals()["app"] = application = build_app()
        return application
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
