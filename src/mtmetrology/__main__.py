"""``mtm`` / ``python -m mtmetrology``: the command line, interrupt-safe from the first
instruction.

This module imports nothing heavy before it can answer Ctrl-C: a SIGINT during start-up
(importing numpy, scipy, pyarrow ... takes about a second) or during a run prints one
line, ``interrupted; nothing written``, and exits with code 130; outputs are written
atomically, so that line is true (in the last instant of a run, after its output was
completed, the line names the output instead).  Once the command has returned, SIGINT is
ignored: the exit of the interpreter has nothing left to stop.
"""

from __future__ import annotations

import sys

INTERRUPTED = "interrupted; nothing written"
EXIT_INTERRUPTED = 130
#: The reader of standard output closed it (``mtm machine list | head -1``): the code of a
#: program ended by SIGPIPE (128 + 13), which a shell does not report.
EXIT_PIPE_CLOSED = 141


def _interrupted() -> None:
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # a second Ctrl-C must not add a traceback
    message = INTERRUPTED
    if "mtmetrology.cli._common" in sys.modules:  # start-up is over: an output may be done
        message = sys.modules["mtmetrology.cli._common"].interrupted_message()
    sys.stderr.write(message + "\n")
    sys.stderr.flush()
    raise SystemExit(EXIT_INTERRUPTED)


def _pipe_closed() -> None:
    """End quietly: the reader took what it wanted. Standard output goes to the null
    device, so that the interpreter's last flush of what is still buffered cannot fail
    again ("Exception ignored ... BrokenPipeError")."""
    import os

    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    raise SystemExit(EXIT_PIPE_CLOSED)


def main(args: list[str] | None = None) -> None:
    """Run ``mtm`` with ``args`` (default: the process arguments) and exit."""
    try:
        import signal  # here, not above: importing it is already a moment to answer

        from mtmetrology._memory import limit_heap_retention

        # before the first large allocation: a run on millions of rows gives back what it
        # frees (mtmetrology._memory)
        limit_heap_retention()
        import typer

        argv = sys.argv[1:] if args is None else list(args)
        from mtmetrology.cli import CLICK_EXCEPTION, build_app, command_of, interrupt_reported

        named = command_of(argv)
        app = build_app(named, listing=named is None)
        try:
            try:
                code = app(args=argv, prog_name="mtm", standalone_mode=False)
            finally:
                # The run is over (done, refused or interrupted): a later Ctrl-C, during
                # the exit of the interpreter, has nothing left to stop.
                signal.signal(signal.SIGINT, signal.SIG_IGN)
        except typer.Abort:
            raise KeyboardInterrupt from None
        except SystemExit as ended:
            # click answers a closed standard output (EPIPE) with exit 1, the code of a bug
            if isinstance(ended.__context__, BrokenPipeError):
                raise ended.__context__ from None
            raise
        except CLICK_EXCEPTION as err:
            err.show()
            raise SystemExit(err.exit_code) from None
        if code == EXIT_INTERRUPTED and not interrupt_reported():
            raise KeyboardInterrupt  # typer turned a Ctrl-C outside the command into 130
        sys.stdout.flush()  # here, where a closed pipe is still ours to answer
    except KeyboardInterrupt:
        _interrupted()
    except BrokenPipeError:
        _pipe_closed()
    raise SystemExit(code if isinstance(code, int) else 0)


if __name__ == "__main__":
    main()
