"""The ``mtm`` command line.

Exit codes: 0 success, 1 internal error (a bug), 2 input error (also rank deficiency,
non-convergence, resource limits), 3 environment error (file system, scheduler),
4 a check that ran and did not confirm (``mtm export check``), 130 interrupted (nothing
written).  Errors are one line on stderr; ``--debug`` shows the
traceback.

``app`` is the whole command line.  :func:`build_app` builds it with only the command a
run asks for (``mtm predict ...`` then imports neither the fitting nor the uncertainty
engine: a smaller, faster start on large records), or, for the bare listing (``mtm``,
``mtm --help``), with each command's one-line summary from :data:`SUMMARIES` and no
command module imported at all.
"""

from __future__ import annotations

import importlib
from typing import Annotated

import typer

from mtmetrology.cli._common import (
    CLICK_EXCEPTION,
    MtmGroup,
    interrupt_reported,
    reflow_commands,
)

__all__ = [
    "CLICK_EXCEPTION",
    "COMMANDS",
    "SHARED_GROUPS",
    "SUMMARIES",
    "app",
    "build_app",
    "command_of",
    "interrupt_reported",
]

_HELP = (
    "mtmetrology: machine-tool and CMM metrology from the command line.\n\n"
    "Exit codes: 0 success, 1 internal error (a bug), 2 input error (also rank deficiency, "
    "non-convergence, resource limits), 3 environment error (file system, scheduler), "
    "4 a check that ran and did not confirm (mtm export check), 130 interrupted (nothing "
    "written)."
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
    "export": ("mtmetrology.cli.export", "app", True),
    "history": ("mtmetrology.cli.history", "app", True),
    "cmm": ("mtmetrology.cli.cmm_studies", "app", True),
    "validate": ("mtmetrology.cli.validate", "app", True),
    "serve": ("mtmetrology.cli.serve", "app", True),
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

#: The first paragraph of each command's help, shown by ``mtm --help`` without importing
#: the command (tests/cli/test_cli_startup.py checks it against the command's own help).
SUMMARIES = {
    "machine": "Machine definitions: list, show, export, check, identifiability.",
    "uncertainty": "Evaluate measurement uncertainty (GUF, Monte Carlo).",
    "fit": "Fit a line, plane, circle, sphere, cylinder or cone to points and report its form.",
    "predict": "Compensated stylus-centre coordinates x, y, z (mm) in the workpiece frame.",
    "gp": "Gaussian-process error model of a CMM (fit on ball-plate records, predict).",
    "design": "Plan calibrations: artefact layout and probing programme.",
    "verify": "Independent checks of a calibrated machine.",
    "repeatability": "Probing repeatability models (on-machine measurement).",
    "task": "Uncertainty of on-machine measurement tasks.",
    "demo": "Run the engines end to end on built-in virtual machines and write a report.",
    "budget": "Task-uncertainty budgets of on-machine measurements.",
    "export": (
        "Write a control's compensation tables and check.json: the residual tool-point error "
        "after the control's own interpolation, with its uncertainty (k = 2), on a grid over "
        "the travel."
    ),
    "history": "Calibration history: record results, control charts, drift, long-term covariance.",
    "cmm": "Bridge-CMM studies on ball-plate records.",
    "validate": "Validate uncertainty statements against calibrated artefacts.",
    "serve": "The laboratory's web application: machines, due dates, trends, audit trail.",
    "calibrate": SHARED_GROUPS["calibrate"][0],
    "simulate": SHARED_GROUPS["simulate"][0],
}


def command_of(argv: list[str]) -> str | None:
    """The command a command line names (its first argument not an option), if it is one."""
    first = next((a for a in argv if not a.startswith("-")), None)
    return first if first in COMMANDS or first in SHARED_GROUPS else None


def _summary_group(name: str) -> typer.Typer:
    group = typer.Typer(help=SUMMARIES[name])
    group.callback()(lambda: None)
    return group


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


def build_app(only: str | None = None, *, listing: bool = False) -> typer.Typer:
    """The ``mtm`` application, with every command or only the one named ``only``.

    ``listing``: every command as its summary only (nothing imported), for ``mtm --help``
    and for a command line naming no command.
    """
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
        if listing:
            if group:
                application.add_typer(_summary_group(name), name=name)
            else:
                application.command(name, help=SUMMARIES[name])(lambda: None)
            continue
        target = getattr(importlib.import_module(module), attribute)
        if group:
            application.add_typer(target, name=name)
        else:
            application.command(name)(target)
    for name in SHARED_GROUPS:
        if only is None or name == only:
            group = _summary_group(name) if listing else _shared_group(name)
            application.add_typer(group, name=name)
    reflow_commands(application)
    return application


def __getattr__(name: str):
    # ``app`` is built on first use, so that importing this package (as ``mtm predict``
    # does) does not import every command's engine.
    if name == "app":
        globals()["app"] = application = build_app()
        return application
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
