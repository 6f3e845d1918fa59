"""The runner of ``mtm demo`` and of the example scripts of ``examples/``.

The demo is the example scripts (:data:`EXAMPLES`), run in order on one folder. Each
script defines ``main(ctx)``, a function of a :class:`DemoContext`: it makes its input
files, computes its results with the library, writes them as JSON/CSV, adds its part to
one HTML report, prints the ``mtm`` commands that redo its steps from those files, and
leaves one line per part for the closing summary. Run on its own
(``python examples/samba_calibration.py [OUT]``), a script calls :func:`run_example`,
which runs it alone through the same machinery.

Everything is written into a temporary folder beside ``out`` and renamed onto it at the
end, so an interrupted run (Ctrl-C) leaves no partial folder. An existing ``out`` is
replaced only if it is a previous demo folder (it holds the ``.mtm-demo`` marker).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import shlex
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

from rich.console import Console
from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

from mtmetrology.errors import InputError, MtmetrologyError
from mtmetrology.io.files import write_json

__all__ = [
    "DEFAULT_SEED",
    "EXAMPLES",
    "MARKER",
    "DemoContext",
    "examples_folder",
    "run_demo",
    "run_example",
]

#: Marks a folder written by ``mtm demo`` or an example script (and so safe to replace).
MARKER = ".mtm-demo"
DEFAULT_SEED = 2026
#: The example scripts of ``mtm demo``, in order (file names in :func:`examples_folder`).
#: A script may read the files an earlier one wrote (the calibration feeds the task).
EXAMPLES = [
    "five_axis_machine.py",
    "samba_planning.py",
    "samba_calibration.py",
    "task_uncertainty.py",
    "gum_h1_uncertainty.py",
    "sphere_fitting.py",
    "cmm_ballplate.py",
]


@dataclass
class DemoContext:
    """What an example needs: where to write, the report, the seed, the console.

    Attributes
    ----------
    out : Path
        The demo folder as the user will find it (commands are printed with it).
    work : Path
        Where files are written during the run (renamed to ``out`` at the end).
    report : mtmetrology.report.Report
        The demo's report; each example adds its sections to it.
    seed : int
        Root seed; examples derive their streams from it.
    console : rich.console.Console
    progress : rich.progress.Progress
    """

    out: Path
    work: Path
    report: object
    seed: int
    console: Console
    progress: Progress
    summary: list[str] = field(default_factory=list)
    commands: list[tuple[str, str]] = field(default_factory=list)

    def path(self, *parts: str) -> Path:
        """A file in the work folder (parents created)."""
        target = self.work.joinpath(*parts)
        target.parent.mkdir(parents=True, exist_ok=True)
        return target

    def shown(self, *parts: str) -> str:
        """The path of a demo file as the user will see it after the run."""
        return str(self.out.joinpath(*parts))

    def write_json(self, document: dict, *parts: str) -> None:
        write_json(self.path(*parts), document)

    def write_text(self, text: str, *parts: str) -> None:
        self.path(*parts).write_text(text, encoding="utf-8")

    def rule(self, title: str) -> None:
        """The title line of one part of an example."""
        self.progress.console.rule(f"[bold]{title}")

    def command(self, purpose: str, *argv: str) -> None:
        """Print ``$ mtm ...`` (a step the user can redo) and list it in the report."""
        line = shlex.join(["mtm", *argv])
        self.commands.append((purpose, line))
        self.console.print(f"  [dim]{purpose}:[/dim] $ {line}", soft_wrap=True)

    @contextmanager
    def step(self, description: str) -> Iterator[None]:
        """A progress line (spinner, bar, elapsed time) around one step of an example."""
        task = self.progress.add_task(description, total=1)
        yield
        self.progress.update(task, completed=1)


def examples_folder() -> Path:
    """``examples/`` of the source tree this package runs from."""
    folder = Path(__file__).resolve().parents[3] / "examples"
    if not (folder / EXAMPLES[0]).is_file():
        raise InputError(
            f"the example scripts are not beside this installation (looked in {folder}); "
            "run from a clone of the repository"
        )
    return folder


def _load_main(path: Path) -> Callable[[DemoContext], None]:
    """``main`` of an example script; its folder is on ``sys.path`` for its helpers."""
    folder = str(path.parent)
    if folder not in sys.path:
        sys.path.insert(0, folder)
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[path.stem] = module  # as a sibling's ``import samba_calibration`` finds it
    spec.loader.exec_module(module)
    return module.main


def _umask() -> int:
    """The process umask (read by setting it and restoring it at once)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _prepare(out: Path) -> Path:
    """A fresh work folder beside ``out``; refuse to replace a folder the demo did not write."""
    if out.exists() and not (out / MARKER).exists():
        raise InputError(f"{out} exists and is not a demo folder; choose another --out")
    out.parent.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    work.chmod(0o777 & ~_umask())  # an ordinary folder once renamed, not a private one
    return work


def _publish(work: Path, out: Path) -> None:
    """Replace ``out`` by the finished work folder (a rename; the old one is removed)."""
    (work / MARKER).write_text("written by mtm demo\n", encoding="utf-8")
    old = None
    if out.exists():
        old = out.with_name(f".{out.name}.old-{time.time_ns()}")
        out.rename(old)
    work.rename(out)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


def _commands_section(ctx: DemoContext) -> None:
    ctx.report.section(
        "Rerun the steps",
        "Each step can be redone from the files of the demo folder with these commands.",
    )
    ctx.report.table(["step", "command"], ctx.commands)


def _run(
    mains: Sequence[Callable[[DemoContext], None]],
    out: Path,
    seed: int,
    title: str,
    command: str,
) -> list[str]:
    from mtmetrology.report import Report

    work = _prepare(out)
    console = Console()
    report = Report(title, command=command, provenance={"seed": seed, "folder": str(out)})
    columns = (SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn())
    try:
        with Progress(*columns, console=console) as progress:
            context = DemoContext(out, work, report, seed, console, progress)
            for main in mains:
                main(context)
        _commands_section(context)
        report.write(work / "report.html")
        _publish(work, out)
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    console.rule("[bold]Summary")
    for line in context.summary:
        console.print(f"- {line}")
    console.print(f"inputs, JSON results and the commands' files: {out}/")
    console.print(f"[bold]report: {out / 'report.html'}[/bold]")
    return context.summary


def run_demo(out: Path, seed: int = DEFAULT_SEED, *, command: str = "mtm demo") -> list[str]:
    """Run the example scripts of :data:`EXAMPLES` in order into ``out``; one report.

    Parameters
    ----------
    out : Path
        The demo folder (replaced only if a previous demo wrote it).
    seed : int
        Root seed of every simulation.
    command : str
        The command line recorded in the report.

    Returns
    -------
    list of str
        The summary lines, one per part, also printed.
    """
    folder = examples_folder()
    mains = [_load_main(folder / name) for name in EXAMPLES]
    return _run(mains, out, seed, "mtmetrology demo", command)


def run_example(main: Callable[[DemoContext], None], name: str) -> list[str]:
    """Run one example script on its own: ``python examples/NAME.py [OUT] [--seed N]``.

    Its files and report go to ``OUT`` (default ``mtm-example-NAME``); the summary lines
    are printed as the demo prints them. A refused request (``OUT`` exists and is not a
    demo folder) prints one ``error:`` line and exits with its code (2).
    """
    parser = argparse.ArgumentParser(prog=f"python examples/{name}.py")
    parser.add_argument("out", nargs="?", type=Path, default=Path(f"mtm-example-{name}"))
    parser.add_argument("--seed", type=int, default=DEFAULT_SEED, help="root seed")
    args = parser.parse_args()
    try:
        return _run([main], args.out, args.seed, f"example {name}", shlex.join(sys.argv))
    except MtmetrologyError as error:  # one line and its exit code, as ``mtm`` prints it
        print(f"error: {error}", file=sys.stderr)
        raise SystemExit(error.exit_code) from None
    except KeyboardInterrupt:
        print("interrupted: nothing written", file=sys.stderr)
        raise SystemExit(130) from None
