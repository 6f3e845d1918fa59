"""Shared command-line plumbing: the one error path of ``mtm`` and the readers of records.

Every command runs inside :class:`MtmGroup`, which turns whatever stops a run into one
line on stderr and a documented exit code (:mod:`mtmetrology.errors`):

- a :class:`~mtmetrology.errors.MtmetrologyError` -> ``error: <message>``, its
  ``exit_code`` (2 for input, rank, convergence and resource limits; 3 for environment);
- ``RecursionError`` / ``MemoryError`` -> exit 2 (the input is too deep or too large);
- any other ``OSError`` (unwritable target, directory given as a file ...) -> exit 3;
- standard output closed by its reader (``mtm machine list | head -1``) -> nothing
  printed, exit 141 (:mod:`mtmetrology.__main__`, as SIGPIPE would end the program);
- Ctrl-C (SIGINT) -> ``interrupted; nothing written``, exit 130 (outputs are written
  atomically, so this is true);
- anything else is a bug -> ``internal error: ...``, exit 1.

Every ``float`` option of every command refuses NaN and ±inf at the door, through one
rule (:func:`finite_number`, attached by :class:`MtmGroup`): ``error: --calibrated: expected
a finite number, got nan``, exit 2, before the command reads a file.

``mtm --debug`` (or ``MTM_DEBUG=1``) lets the traceback through instead.
"""

from __future__ import annotations

import inspect
import json
import math
import os
import shlex
import sys
from collections.abc import Callable
from functools import wraps
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from typer.core import TyperGroup

from mtmetrology.errors import (
    EXIT_ENVIRONMENT,
    EXIT_INPUT,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    InputError,
    MtmetrologyError,
)
from mtmetrology.io.files import committed

if TYPE_CHECKING:  # loaded by the commands that use them: mtm --help needs none
    import numpy as np

    from mtmetrology.io.tables import Table
    from mtmetrology.kinematics.machine import Machine

__all__ = [
    "CLICK_EXCEPTION",
    "INTERRUPTED",
    "ArtefactOption",
    "CoverageK",
    "CoverageP",
    "ErrorModelOption",
    "MachineOption",
    "MtmGroup",
    "ParamsOnlyOption",
    "coverage_from_options",
    "describe_failure",
    "fail",
    "finite_number",
    "interrupt_reported",
    "interrupted_message",
    "print_json",
    "readings_from_table",
    "senses_from_table",
    "user_errors",
    "vector_option",
]

INTERRUPTED = "interrupted; nothing written"
#: Typer's usage errors (its own or click's, depending on the Typer version).
CLICK_EXCEPTION = next(c for c in typer.BadParameter.__mro__ if c.__name__ == "ClickException")
_REPORTED: list[bool] = []  # set when the interruption line has been printed


def interrupted_message(since: int = 0) -> str:
    """:data:`INTERRUPTED`, or, if the interruption came after an output was completed
    (the last instant of a run), which output is complete.

    ``since`` is the number of outputs the process had completed before this run."""
    done = committed()[since:]
    if not done:
        return INTERRUPTED
    return f"interrupted; {', '.join(str(p) for p in done)} written completely"


def interrupt_reported() -> bool:
    """Whether this process already printed :data:`INTERRUPTED`."""
    return bool(_REPORTED)


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def describe_failure(err: BaseException, outputs_before: int = 0) -> tuple[str, int]:
    """The one-line message and exit code for an exception.

    ``outputs_before``: outputs the process had completed before the run (an interruption
    says which outputs of this run are complete, if any).

    Examples
    --------
    >>> describe_failure(InputError("a.csv, line 3: column 'X' holds 'x', not a number"))
    ("error: a.csv, line 3: column 'X' holds 'x', not a number", 2)
    >>> describe_failure(PermissionError(13, "Permission denied", "out.csv"))
    ('error: out.csv: Permission denied', 3)
    """
    if isinstance(err, KeyboardInterrupt):
        return interrupted_message(outputs_before), EXIT_INTERRUPTED
    if isinstance(err, MtmetrologyError):
        return f"error: {_one_line(err)}", err.exit_code
    if isinstance(err, RecursionError):
        return "error: the input is nested too deeply to be processed", EXIT_INPUT
    if isinstance(err, MemoryError):
        return "error: the input is too large for the available memory", EXIT_INPUT
    if isinstance(err, OSError):
        where = f"{err.filename}: " if err.filename else ""
        return f"error: {where}{err.strerror or _one_line(err)}", EXIT_ENVIRONMENT
    name = type(err).__name__
    return (
        f"internal error: {name}: {_one_line(err)} (a bug: please report it; "
        "mtm --debug shows the traceback)",
        EXIT_INTERNAL,
    )


def _option_name(param) -> str:
    """The name a user types for ``param``: its long option (``--u-cal``, not ``-u``)."""
    opts = list(getattr(param, "opts", None) or [])
    return next((o for o in opts if o.startswith("--")), opts[0] if opts else param.name)


def finite_number(ctx: typer.Context, param, value: float | None) -> float | None:
    """The check of every ``float`` option of ``mtm``: NaN and ±inf are refused.

    Typer accepts ``nan`` and ``inf`` as floats; no option of ``mtm`` means either, and a
    NaN let through becomes a printed ``U nan`` (issue 30).  Raised as
    :class:`InputError`, so the refusal is one line naming the option, exit 2.

    Raises
    ------
    InputError
        ``value`` is NaN or infinite.
    """
    if value is not None and not math.isfinite(value):
        raise InputError(f"{_option_name(param)}: expected a finite number, got {value}")
    return value


def _chain(first: Callable, then: Callable | None) -> Callable:
    if then is None:
        return first
    return lambda ctx, param, value: then(ctx, param, first(ctx, param, value))


def refuse_non_finite(command) -> None:
    """Attach :func:`finite_number` to every ``float`` parameter of ``command`` and of its
    subcommands (before the parameter's own callback, if it has one)."""
    for param in command.params:
        descriptor = getattr(param, "type_descriptor", None)
        if descriptor is not None and descriptor.annotation is float:
            param.callback = _chain(finite_number, param.callback)
    for sub in getattr(command, "commands", {}).values():
        refuse_non_finite(sub)


class MtmGroup(TyperGroup):
    """The ``mtm`` command group: every failure leaves through :func:`describe_failure`,
    and every ``float`` option refuses NaN and ±inf (:func:`refuse_non_finite`)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        refuse_non_finite(self)

    def invoke(self, ctx: typer.Context):
        debug = bool(ctx.params.get("debug")) or os.environ.get("MTM_DEBUG", "") not in ("", "0")
        outputs_before = len(committed())
        try:
            return super().invoke(ctx)
        except (typer.Exit, typer.Abort, CLICK_EXCEPTION, BrokenPipeError):
            raise  # a closed standard output is no failure: mtmetrology.__main__ ends quietly
        except KeyboardInterrupt:
            message, code = describe_failure(KeyboardInterrupt(), outputs_before)
            _REPORTED.append(True)
        except Exception as err:
            if debug:
                raise
            message, code = describe_failure(err)
        typer.echo(message, err=True)
        raise typer.Exit(code)


#: Widest verbatim help line (tables, YAML examples) that an 80-column terminal shows
#: unwrapped: rich pads the help panel by one column each side.
HELP_WIDTH = 78


def reflow_help(text: str | None) -> str | None:
    """A command's help with each prose paragraph on one line, for the terminal to wrap.

    Typer keeps the line breaks of a paragraph after the first and the terminal wraps
    each line again: at 80 columns a docstring wrapped at 90 broke mid-sentence twice
    (issue 18).  A paragraph that starts with ``\\b`` or holds an indented line (a table,
    a YAML example) is kept as written; its lines must fit :data:`HELP_WIDTH`.

    Examples
    --------
    >>> reflow_help("Fit a sphere.\\n\\nPoints are\\nread in mm.\\n\\n  x  mm\\n  y  mm")
    'Fit a sphere.\\n\\nPoints are read in mm.\\n\\n  x  mm\\n  y  mm'
    """
    if not text:
        return text
    paragraphs = inspect.cleandoc(text).split("\n\n")
    out = []
    for para in paragraphs:
        lines = para.split("\n")
        verbatim = para.startswith("\b") or any(ln.startswith((" ", "\t")) for ln in lines)
        out.append(para if verbatim else " ".join(ln.strip() for ln in lines))
    return "\n\n".join(out)


def reflow_commands(app: typer.Typer) -> None:
    """:func:`reflow_help` on every command of ``app`` and of its groups, in place."""
    for info in app.registered_commands:
        info.help = reflow_help(info.help or inspect.getdoc(info.callback))
    for group in app.registered_groups:
        reflow_commands(group.typer_instance)


def fail(message: str) -> None:
    """Refuse the request: raise :class:`InputError` (``error: message``, exit code 2)."""
    raise InputError(message)


def user_errors(func: Callable) -> Callable:
    """Let a command's plain ``ValueError``/``KeyError`` leave as input errors (exit 2).

    The library's own errors (:class:`MtmetrologyError`) pass unchanged to
    :class:`MtmGroup`, which prints them with their exit code.
    """

    @wraps(func)
    def wrapper(*args, **kwargs):
        try:
            return func(*args, **kwargs)
        except MtmetrologyError:
            raise
        except (ValueError, KeyError) as err:
            msg = err.args[0] if isinstance(err, KeyError) and err.args else str(err)
            raise InputError(str(msg)) from err

    return wrapper


def print_json(document: dict) -> None:
    """Write a JSON document on standard output (NaN refused: never a result)."""
    sys.stdout.write(json.dumps(document, indent=2, ensure_ascii=False, allow_nan=False) + "\n")


def readings_from_table(machine: Machine, table: Table) -> np.ndarray:
    """:func:`mtmetrology.kinematics.readings_table.readings_from_table`, loaded on use."""
    from mtmetrology.kinematics import readings_table

    return readings_table.readings_from_table(machine, table)


def senses_from_table(machine: Machine, table: Table) -> np.ndarray | None:
    """:func:`mtmetrology.kinematics.readings_table.senses_from_table`, loaded on use."""
    from mtmetrology.kinematics import readings_table

    return readings_table.senses_from_table(machine, table)


def vector_option(text: str, option: str, unit: str = "mm") -> tuple[float, float, float]:
    """Three comma-separated numbers of an option (``--end-a 10,0,5``), refused with one
    line naming the option unless there are three finite numbers."""
    parts = [p for p in text.split(",") if p.strip()]
    try:
        values = tuple(float(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise InputError(f"{option} needs three numbers x,y,z in {unit}, got {text!r}")
    return values


MachineOption = Annotated[str, typer.Option("--machine", help="Preset name or machine YAML.")]
ArtefactOption = Annotated[Path, typer.Option("--artefact", help="ARTEFACT.yaml.")]
ErrorModelOption = Annotated[
    str | None, typer.Option("--model", help="Error model: 13, 84 or a model name.")
]
ParamsOnlyOption = Annotated[
    str | None,
    typer.Option("--params-only", help="Identify only these parameters (E_X0C,E_A0C,...)."),
]
KeepAPrioriOption = Annotated[
    bool,
    typer.Option(
        "--keep-a-priori-covariance",
        help="Keep the covariance of the stated noise even when the residuals contradict it "
        "(chi-squared p < 0.01); by default it is then scaled by the variance factor s².",
    ),
]


#: ``--k``: the coverage factor of every U the command states (with :data:`CoverageP`).
CoverageK = Annotated[
    float | None,
    typer.Option("--k", help="Coverage factor k of U = k u [2, about 95 %; EA-4/02]."),
]
#: ``--p``: the coverage probability instead (k = Φ⁻¹((1 + p)/2) for a normal output).
CoverageP = Annotated[
    float | None,
    typer.Option("--p", help="Coverage probability instead of --k (0 < p < 1)."),
]


def coverage_from_options(k: float | None, p: float | None):
    """The :class:`~mtmetrology.uncertainty.coverage.CoveragePolicy` of ``--k`` / ``--p``.

    Raises
    ------
    InputError
        Both given, k not finite and > 0, p outside (0, 1).
    """
    from mtmetrology.uncertainty.coverage import coverage_policy

    return coverage_policy(k, p)


def adequacy_rule(keep_a_priori: bool) -> str:
    """The identification engine's adequacy rule for ``--keep-a-priori-covariance``."""
    return "a-priori" if keep_a_priori else "scale"


ReportOption = Annotated[
    Path | None,
    typer.Option(
        "--report",
        help="Also write a self-contained HTML report (tables, figures, provenance) here.",
        dir_okay=False,
    ),
]


def command_line(ctx: typer.Context) -> str:
    """The running command as a user would type it, rebuilt from its parsed parameters.

    Options left at their default are omitted, so the line reruns the same command.
    (Rebuilt rather than read from ``sys.argv``, which is the test runner's under
    ``CliRunner`` and ``python -m``'s when run as a module.)
    """
    words = ctx.command_path.split()
    words[0] = "mtm"
    for param in ctx.command.params:
        value = ctx.params.get(param.name)
        if value is None or value == param.get_default(ctx) or param.expose_value is False:
            continue
        if param.param_type_name == "argument":
            words += [str(v) for v in value] if isinstance(value, list | tuple) else [str(value)]
        elif getattr(param, "is_flag", False):
            flag = param.opts[0] if value else (param.secondary_opts or [None])[0]
            words += [flag] if flag else []
        else:
            values = value if isinstance(value, list | tuple) else [value]
            for v in values:
                words += [param.opts[0], str(getattr(v, "value", v))]
    return shlex.join(words)


def emit_result(
    document: dict,
    summary: str | Callable[[], object] | None,
    *,
    output: Path | None,
    report,
    report_path: Path | None,
    as_json: bool,
    messages: Callable[[], object] | None = None,
) -> None:
    """The end of every command that computes a result: write its JSON (``-o``) and its
    report (``--report``, built before anything is written), then print the JSON or the
    console summary on standard output, then the messages on standard error.

    ``summary`` is the summary text, or a function that prints it (called only when the
    JSON is not printed), or None (the command's console lines are all messages).
    ``messages`` prints on standard error what is said whether or not the JSON is printed
    (warnings, the files written), so that standard output stays the data.
    """
    from mtmetrology.io.files import write_json

    if output is not None:
        write_json(output, document)
    if report is not None:
        write_report(report, report_path)
    if as_json:
        print_json(document)
    elif callable(summary):
        summary()
    elif summary is not None:
        typer.echo(summary)
    if messages is not None:
        messages()


def write_report(report, path: Path) -> None:
    """Write ``report`` atomically to ``path`` and say so on stderr (stdout stays data)."""
    try:
        report.write(path)
    except OSError as exc:
        fail(f"{path}: cannot write the report ({exc.strerror or exc})")
    typer.echo(f"report written to {path}", err=True)


def machine_with_parameters(machine: str, params: Path | None):
    """The machine of a preset or file with the errors of an optional parameter set.

    Returns ``(machine, theta)``: the machine restricted to the set's parameters
    (:meth:`ParameterSet.machine_for`) and their values, or the machine and None (zero
    errors) without a set.
    """
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.parameter_set import ParameterSet

    m = Machine.load(machine)
    if params is None:
        return m, None
    pset = ParameterSet.load(params, m)
    m = pset.machine_for(m)
    return m, pset.vector_for(m)


def parse_tools(options: list[str] | None) -> dict[str, tuple[float, float, float]] | None:
    """``{id: vector}`` of the ``--tool ID=x,y,z`` options (None without one)."""
    if not options:
        return None
    out: dict[str, tuple[float, float, float]] = {}
    for text in options:
        name, sep, vector = text.partition("=")
        if not sep or not name.strip():
            raise InputError(f"--tool needs ID=x,y,z (mm), got {text!r}")
        if name.strip() in out:
            raise InputError(f"--tool {name.strip()!r} is given twice")
        out[name.strip()] = vector_option(vector, f"--tool {name.strip()}")
    return out
