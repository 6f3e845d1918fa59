"""The ``mtm`` command line.

Exit codes: 0 success, 1 internal error (a bug), 2 input error (also rank deficiency,
non-convergence, resource limits), 3 environment error (file system, scheduler),
4 a check that ran and did not confirm (``mtm export check``), 130 interrupted (nothing
written), 141 standard output closed by its reader (``mtm ... | head``; nothing printed).
Errors are one line on stderr; ``--debug`` shows the
traceback.

``app`` is the whole command line.  :func:`build_app` builds it with only the command a
run asks for (``mtm predict ...`` then imports neither the fitting nor the uncertainty
engine: a smaller, faster start on large records), or, for the bare listing (``mtm``,
``mtm --help``), with each command's one-line summary from :data:`SUMMARIES` and no
command module imported at all.
"""

from __future__ import annotations

import copy
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
    "ALIASES",
    "CLICK_EXCEPTION",
    "COMMANDS",
    "NOUNS",
    "QUANTITIES",
    "SHARED_GROUPS",
    "SUMMARIES",
    "TOP_LEVEL_VERBS",
    "VERBS",
    "app",
    "build_app",
    "command_of",
    "interrupt_reported",
]

_HELP = (
    "mtmetrology: machine-tool and CMM metrology from the command line.\n\n"
    "Commands read noun first, mtm <noun> <action> (mtm samba calibrate); fit, predict, "
    "export, demo and formats act on files.\n\n"
    "Exit codes: 0 success, 1 internal error (a bug), 2 input error (also rank deficiency, "
    "non-convergence, resource limits), 3 environment error (file system, scheduler), "
    "4 a check that ran and did not confirm (mtm export check), 130 interrupted (nothing "
    "written), 141 standard output closed by its reader (mtm ... | head)."
)

#: Command name -> (module, attribute, whether it is a group of subcommands).
COMMANDS = {
    "machine": ("mtmetrology.cli.machine", "app", True),
    "uncertainty": ("mtmetrology.cli.uncertainty", "app", True),
    "fit": ("mtmetrology.cli.fit", "fit", False),
    "predict": ("mtmetrology.cli.predict", "predict", False),
    "gp": ("mtmetrology.cli.cmm", "gp_app", True),
    "repeatability": ("mtmetrology.cli.repeatability", "app", True),
    "demo": ("mtmetrology.cli.demo", "demo", False),
    "budget": ("mtmetrology.cli.budget", "app", True),
    "export": ("mtmetrology.cli.export", "app", True),
    "history": ("mtmetrology.cli.history", "app", True),
    "ballbar": ("mtmetrology.cli.ballbar", "app", True),
    "rtest": ("mtmetrology.cli.rtest", "app", True),
    "laser": ("mtmetrology.cli.laser", "app", True),
    "formats": ("mtmetrology.cli.formats", "formats", False),
    "serve": ("mtmetrology.cli.serve", "app", True),
}

#: Noun groups whose subcommands come from several applications (``mtm samba calibrate``,
#: ``mtm samba plan``): name -> (help, [(module, Typer app, {its command: verb here} or
#: None for all its commands under their own names)]).
SHARED_GROUPS = {
    "samba": (
        "SAMBA test of a five-axis machine: simulate, calibrate, plan, unexplained error.",
        [
            ("mtmetrology.cli.simulate", "app", {"samba": "simulate"}),
            ("mtmetrology.cli.calibrate", "app", {"samba": "calibrate"}),
            ("mtmetrology.cli.design", "app", {"samba": "plan", "compare": "compare-plans"}),
            ("mtmetrology.cli.calibrate", "app", {"unexplained": "unexplained"}),
            ("mtmetrology.cli.long_term", "app", {"long-term": "long-term"}),
        ],
    ),
    "tracker": (
        "Laser-tracker verification of a machine tool: simulate, calibrate, verify, plan.",
        [
            ("mtmetrology.cli.tracker", "simulate_app", {"tracker": "simulate"}),
            ("mtmetrology.cli.tracker", "calibrate_app", {"tracker": "calibrate"}),
            ("mtmetrology.cli.tracker", "verify_app", {"tracker": "verify"}),
            ("mtmetrology.cli.tracker", "design_app", {"tracker-placement": "plan"}),
        ],
    ),
    "multilateration": (
        "Sequential multilateration of a machine: simulate, calibrate.",
        [
            ("mtmetrology.cli.multilateration", "simulate_app", {"multilateration": "simulate"}),
            ("mtmetrology.cli.multilateration", "calibrate_app", {"multilateration": "calibrate"}),
        ],
    ),
    "cmm": (
        "Bridge CMM on ball-plate records: simulate, calibrate, budget, studies.",
        [
            ("mtmetrology.cli.cmm", "app", {"simulate": "simulate"}),
            ("mtmetrology.cli.cmm_studies", "app", {"calibrate": "calibrate"}),
            ("mtmetrology.cli.cmm", "app", {"budget": "budget"}),
            ("mtmetrology.cli.cmm_studies", "app", None),
        ],
    ),
    "length": (
        "Length checks: simulate, verify a compensation, predict lengths with u(L).",
        [
            ("mtmetrology.cli.simulate", "app", {"length": "simulate"}),
            ("mtmetrology.cli.verify", "app", {"length": "verify", "lengths": "predict"}),
        ],
    ),
    "task": (
        "Uncertainty of on-machine measurement tasks, and its validation.",
        [
            ("mtmetrology.cli.task", "app", None),
            (
                "mtmetrology.cli.validate",
                "app",
                {"task": "validate", "pooling": "validate-pooling"},
            ),
        ],
    ),
}

#: The old, verb-first spellings, kept hidden for one release (docs/cli.md): old group ->
#: {old subcommand: the command it now is}. Each run prints one note naming the new one.
ALIASES = {
    "calibrate": {
        "samba": "samba calibrate",
        "unexplained": "samba unexplained",
        "long-term": "samba long-term",
        "ballplate": "cmm calibrate",
        "ballplate-budget": "cmm budget",
        "multilateration": "multilateration calibrate",
        "tracker": "tracker calibrate",
    },
    "simulate": {
        "samba": "samba simulate",
        "length": "length simulate",
        "ballplate": "cmm simulate",
        "multilateration": "multilateration simulate",
        "tracker": "tracker simulate",
    },
    "verify": {
        "length": "length verify",
        "lengths": "length predict",
        "tracker": "tracker verify",
    },
    "design": {
        "samba": "samba plan",
        "compare": "samba compare-plans",
        "tracker-placement": "tracker plan",
    },
    "validate": {"task": "task validate", "pooling": "task validate-pooling"},
}

#: The first paragraph of each command's help, shown by ``mtm --help`` without importing
#: the command (tests/cli/test_cli_startup.py checks it against the command's own help).
SUMMARIES = {
    "machine": "Machine definitions: list, show, export, check, identifiability.",
    "samba": SHARED_GROUPS["samba"][0],
    "tracker": SHARED_GROUPS["tracker"][0],
    "multilateration": SHARED_GROUPS["multilateration"][0],
    "cmm": SHARED_GROUPS["cmm"][0],
    "gp": "Gaussian-process error model of a CMM (fit on ball-plate records, predict).",
    "length": SHARED_GROUPS["length"][0],
    "task": SHARED_GROUPS["task"][0],
    "budget": "Task-uncertainty budgets of on-machine measurements.",
    "uncertainty": "Evaluate measurement uncertainty (GUF, Monte Carlo).",
    "repeatability": "Probing repeatability models (on-machine measurement).",
    "history": "Calibration history: record results, control charts, drift, long-term covariance.",
    "fit": "Fit a line, plane, circle, sphere, cylinder or cone to points and report its form.",
    "predict": "Compensated stylus-centre coordinates x, y, z (mm) in the workpiece frame.",
    "export": (
        "Write a control's compensation tables and check.json: the residual tool-point error "
        "after the control's own interpolation, with its uncertainty (k = 2), on a grid over "
        "the travel."
    ),
    "ballbar": (
        "ISO 230-4 circular tests with a ballbar: simulate, analyse (G, H, F), calibrate "
        "(identify the plane's ISO 230-1 errors and servo terms)."
    ),
    "rtest": (
        "Static R-test of the rotary axes: simulate, calibrate (location errors and error "
        "motions by rank)."
    ),
    "laser": "ISO 230-2 positioning tests with a laser interferometer: simulate, analyse.",
    "demo": "Run the engines end to end on built-in virtual machines and write a report.",
    "formats": "The file formats mtm reads and writes: list them, or describe one.",
    "serve": "The laboratory's web application: machines, due dates, trends, audit trail.",
}

#: The grammar (docs/cli.md; tests/cli/test_cli_grammar.py walks the tree against it):
#: ``mtm <noun> <action>``; a few top-level verbs act on files.
NOUNS = frozenset(
    {"machine", "samba", "tracker", "multilateration", "cmm", "gp", "length", "task",
     "budget", "uncertainty", "repeatability", "history", "laser", "ballbar", "rtest"}
)  # fmt: skip
#: Top-level verbs acting on files (and ``formats``, the listing of the file formats).
TOP_LEVEL_VERBS = frozenset({"fit", "predict", "export", "demo", "serve", "formats"})
#: The second word: a verb, or the quantity the command evaluates (``mtm task uncertainty``,
#: ``mtm history drift``) or the kind of budget (``mtm budget iso15530-3``).
VERBS = frozenset(
    {"simulate", "calibrate", "verify", "plan", "compare-plans", "compare", "predict", "fit",
     "validate", "validate-pooling", "list", "show", "export", "check", "add", "run",
     "budget", "import", "dcc-import", "analyse", "upgrade", "amend"}
)  # fmt: skip
QUANTITIES = frozenset(
    {"uncertainty", "unexplained", "long-term", "identifiability", "hysteresis", "trend",
     "drift", "covariance", "dcc", "iso15530-3", "volumetric-map", "source-gp",
     "selfcal-design"}
)  # fmt: skip


def command_of(argv: list[str]) -> str | None:
    """The command a command line names (its first argument not an option), if it is one."""
    first = next((a for a in argv if not a.startswith("-")), None)
    known = first in COMMANDS or first in SHARED_GROUPS or first in ALIASES
    return first if known else None


def _summary_group(name: str) -> typer.Typer:
    group = typer.Typer(help=SUMMARIES[name])
    group.callback()(lambda: None)
    return group


def _group_commands(name: str) -> dict:
    """The commands of the noun group ``name``: verb -> Typer command info (a copy, renamed)."""
    commands = {}
    for module, attribute, renames in SHARED_GROUPS[name][1]:
        member = getattr(importlib.import_module(module), attribute)
        for info in member.registered_commands:
            own = info.name or info.callback.__name__.replace("_", "-")
            if renames is None or own in renames:
                commands[own if renames is None else renames[own]] = copy.copy(info)
    for verb, info in commands.items():
        info.name = verb
    return commands


def _shared_group(name: str) -> typer.Typer:
    group = typer.Typer(help=SHARED_GROUPS[name][0], no_args_is_help=True)
    # A callback keeps a one-command group a group.
    group.callback()(lambda: None)
    group.registered_commands.extend(_group_commands(name).values())
    return group


def _alias_group(old: str) -> typer.Typer:
    """The hidden group of an old spelling: each command is the new one under its old name,
    and a run (``--help`` included) first prints one note naming the new spelling."""
    group = typer.Typer(
        help="Old spellings (one release): see `mtm --help` and docs/cli.md.",
        no_args_is_help=True,
    )

    def note(ctx: typer.Context) -> None:
        # click runs a group's callback before it parses the subcommand's arguments (and
        # its --help), so the note comes first whatever the subcommand then does
        if ctx.invoked_subcommand in ALIASES[old]:
            new = ALIASES[old][ctx.invoked_subcommand]
            typer.echo(f"note: `mtm {old} {ctx.invoked_subcommand}` is now `mtm {new}`", err=True)

    group.callback()(note)
    nouns: dict[str, dict] = {}
    for sub, new in ALIASES[old].items():
        noun, verb = new.split()
        if noun not in nouns:
            nouns[noun] = _group_commands(noun)
        info = nouns[noun][verb]
        info.name = sub
        group.registered_commands.append(info)
    return group


def _version(value: bool) -> None:
    if value:
        from importlib.metadata import version

        typer.echo(f"mtmetrology {version('mtmetrology')}")
        raise typer.Exit()


def _options(
    debug: Annotated[
        bool, typer.Option("--debug", help="Show the traceback of an error (for bug reports).")
    ] = False,
    show_version: Annotated[
        bool,
        typer.Option(
            "--version", help="Print the version and exit.", is_eager=True, callback=_version
        ),
    ] = False,
) -> None:
    """mtmetrology: machine-tool and CMM metrology from the command line."""


def build_app(only: str | None = None, *, listing: bool = False) -> typer.Typer:
    """The ``mtm`` application, with every command or only the one named ``only``.

    ``listing``: every command as its summary only (nothing imported), for ``mtm --help``
    and for a command line naming no command.  The old spellings (:data:`ALIASES`) are
    hidden groups, built only when a command line names one or for the whole application.
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
    for name in SUMMARIES:
        if only is not None and name != only:
            continue
        if name in SHARED_GROUPS:
            group = _summary_group(name) if listing else _shared_group(name)
            application.add_typer(group, name=name)
            continue
        module, attribute, is_group = COMMANDS[name]
        if listing:
            if is_group:
                application.add_typer(_summary_group(name), name=name)
            else:
                application.command(name, help=SUMMARIES[name])(lambda: None)
            continue
        target = getattr(importlib.import_module(module), attribute)
        if is_group:
            application.add_typer(target, name=name)
        else:
            application.command(name)(target)
    for name in ALIASES:
        if not listing and (only is None or name == only):
            application.add_typer(_alias_group(name), name=name, hidden=True)
    reflow_commands(application)
    return application


def __getattr__(name: str):
    # ``app`` is built on first use, so that importing this package (as ``mtm predict``
    # does) does not import every command's engine.
    if name == "app":
        globals()["app"] = application = build_app()
        return application
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
