"""One exception hierarchy for every failure a user can meet.

Every error the library raises on purpose derives from :class:`MtmetrologyError`, so a
caller (and the ``mtm`` command line) can tell a refused input from a bug::

    MtmetrologyError
    ├── InputError            bad input: a file, line, field, column or parameter (exit 2)
    │   ├── RankDeficientError    an identification cannot separate its unknowns
    │   └── ResourceLimitError    a request beyond the bounded resources (trials, depth ...)
    ├── ConvergenceError      an iterative method stopped without meeting its criterion (exit 2)
    └── EnvironmentFailure    the machine, not the input: unwritable output, unreachable
                              scheduler, missing system tool (exit 3)

:class:`InputError` is also a :class:`ValueError`, so ``except ValueError`` keeps working
for callers that predate the hierarchy.  Messages name what is wrong and where
(``machine.yaml: axes.X.travel_mm: ...``; ``records.csv, line 12: column 'X' ...``), in one
line; the command line prints them as they are.

Exit codes of ``mtm`` (documented in ``mtm --help``):

====  ==========================================================
0     success
1     internal error (a bug: please report it; ``--debug`` shows the traceback)
2     input error, rank deficiency, non-convergence, resource limit
3     environment error (file system, scheduler, system tools)
4     a check ran and did not confirm (``mtm export check``: the verdict is in its output)
130   interrupted (Ctrl-C); nothing was written
====  ==========================================================
"""

from __future__ import annotations

__all__ = [
    "EXIT_ENVIRONMENT",
    "EXIT_INPUT",
    "EXIT_INTERNAL",
    "EXIT_INTERRUPTED",
    "EXIT_NOT_CONFIRMED",
    "ConvergenceError",
    "EnvironmentFailure",
    "InputError",
    "MtmetrologyError",
    "RankDeficientError",
    "ResourceLimitError",
]

EXIT_INTERNAL = 1
EXIT_INPUT = 2
EXIT_ENVIRONMENT = 3
#: A verification that ran and whose verdict is not "confirmed" (not an error of the run).
EXIT_NOT_CONFIRMED = 4
EXIT_INTERRUPTED = 130


class MtmetrologyError(Exception):
    """Base class of the errors mtmetrology raises on purpose.

    Attributes
    ----------
    exit_code : int
        The ``mtm`` exit code for this kind of failure.
    """

    exit_code = EXIT_INPUT


class InputError(MtmetrologyError, ValueError):
    """Input that cannot be used: the message names the file, line, field or parameter."""


class RankDeficientError(InputError):
    """An identification whose unknowns the measurements cannot separate.

    Attributes
    ----------
    confounded : tuple of tuple of str
        The names in each unidentifiable combination, e.g. ``(("E_Y0C", "E_Y0S"),)``.
    """

    def __init__(self, message: str, confounded: tuple[tuple[str, ...], ...] = ()):
        super().__init__(message)
        self.confounded = tuple(tuple(c) for c in confounded)


class ResourceLimitError(InputError):
    """A request beyond the limits that keep a run bounded in time and memory."""


class ConvergenceError(MtmetrologyError):
    """An iterative method (Newton, Gauss–Newton, adaptive Monte Carlo) did not converge."""


class EnvironmentFailure(MtmetrologyError):
    """A failure of the environment rather than of the input (exit code 3)."""

    exit_code = EXIT_ENVIRONMENT
