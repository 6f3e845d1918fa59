"""The one error path of ``mtm`` (mtmetrology.cli._common.MtmGroup, mtmetrology.__main__)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

from mtmetrology.cli._common import MtmGroup
from mtmetrology.errors import EnvironmentFailure, InputError, ResourceLimitError

#: ``mtm`` as its console script runs it.
MTM = [sys.executable, "-c", "from mtmetrology.__main__ import main; main()"]

FAILURES = {
    "input": InputError("records.csv, line 3: column 'X' holds 'x', not a number"),
    "limit": ResourceLimitError("--trials 10000000000000: give 2 to 50000000 trials"),
    "environment": EnvironmentFailure("out.csv: cannot write: No space left on device"),
    "permission": PermissionError(13, "Permission denied", "out.csv"),
    "directory": IsADirectoryError(21, "Is a directory", "results"),
    "recursion": RecursionError("maximum recursion depth exceeded"),
    "memory": MemoryError(),
    "interrupt": KeyboardInterrupt(),
    "bug": TypeError("unsupported operand type(s)"),
}
EXPECTED = {
    "input": (2, "error: records.csv, line 3: column 'X' holds 'x', not a number"),
    "limit": (2, "error: --trials 10000000000000: give 2 to 50000000 trials"),
    "environment": (3, "error: out.csv: cannot write: No space left on device"),
    "permission": (3, "error: out.csv: Permission denied"),
    "directory": (3, "error: results: Is a directory"),
    "recursion": (2, "error: the input is nested too deeply to be processed"),
    "memory": (2, "error: the input is too large for the available memory"),
    "interrupt": (130, "interrupted; nothing written"),
}


def _app() -> typer.Typer:
    app = typer.Typer(cls=MtmGroup, pretty_exceptions_enable=False)

    @app.callback()
    def _options(debug: bool = typer.Option(False, "--debug")) -> None:
        """Test application."""

    @app.command()
    def fail(kind: str) -> None:
        raise FAILURES[kind]

    return app


@pytest.mark.parametrize("kind", sorted(EXPECTED))
def test_every_failure_is_one_line_and_a_documented_exit_code(kind):
    result = CliRunner().invoke(_app(), ["fail", kind])
    code, line = EXPECTED[kind]
    assert (result.exit_code, result.stderr.splitlines(), result.stdout) == (code, [line], "")


def test_a_bug_is_an_internal_error_and_debug_shows_the_traceback():
    result = CliRunner().invoke(_app(), ["fail", "bug"])
    assert result.exit_code == 1 and len(result.stderr.splitlines()) == 1
    assert result.stderr.startswith("internal error: TypeError: unsupported operand")
    debug = CliRunner().invoke(_app(), ["--debug", "fail", "bug"])
    assert isinstance(debug.exception, TypeError)


def test_sigint_during_start_up_is_one_line_and_130(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2] / "src")}
    process = subprocess.Popen(
        # machine show builds a machine (numpy, the kinematics); machine list loads no numpy
        [*MTM, "machine", "show", "five-axis-wcbxfzyst"],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    # Signal once numpy is mapped: the interpreter is up and the entry point's handler is in
    # place (it runs before any import of the command line), which is still start-up. A
    # fixed sleep is not enough on a loaded machine: a signal before the interpreter has
    # started kills it (return code -2), a window no Python program can close.
    maps = Path(f"/proc/{process.pid}/maps")
    deadline = time.monotonic() + 60
    while process.poll() is None and time.monotonic() < deadline:
        try:
            if "_multiarray_umath" in maps.read_text():
                break
        except OSError:
            break
        time.sleep(0.005)
    process.send_signal(signal.SIGINT)
    _, stderr = process.communicate(timeout=60)
    if process.returncode == 0:  # pragma: no cover - a very fast machine finished first
        pytest.skip("the command finished before the signal")
    assert process.returncode == 130, stderr
    assert stderr.decode().splitlines() == ["interrupted; nothing written"]


@pytest.mark.parametrize(
    "args", [["machine", "list"], ["--help"], ["machine", "show", "three-axis-xfyz"]]
)
def test_a_closed_pipe_ends_quietly(args):
    """``mtm machine list | head -1``: the reader closed standard output before mtm wrote;
    nothing on stderr (no "error: Broken pipe") and the code of a SIGPIPE end, 141."""
    read_end, write_end = os.pipe()
    os.close(read_end)  # the reader is gone before the first line is written
    try:
        run = subprocess.run(
            [sys.executable, "-m", "mtmetrology", *args],
            stdout=write_end,
            stderr=subprocess.PIPE,
            text=True,
            timeout=120,
        )
    finally:
        os.close(write_end)
    assert (run.returncode, run.stderr) == (141, "")
