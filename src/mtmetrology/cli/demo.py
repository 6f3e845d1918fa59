"""``mtm demo``: the engines end to end on built-in virtual machines, no input files.

The demo runs a sequence of sections (:data:`mtmetrology.cli.demo_sections.DEMO_SECTIONS`).
Each section makes its input files, computes its results with the library, writes them
as JSON/CSV, adds its part to one HTML report, prints the ``mtm`` commands that redo its
steps from those files, and leaves one line for the closing summary. An application adds
its section by appending a :class:`DemoSection` to that list.

Everything is written into a temporary folder beside ``--out`` and renamed onto it at the
end, so an interrupted run (Ctrl-C) leaves no partial demo folder. An existing ``--out``
is replaced only if it is a previous demo folder (it holds the ``.mtm-demo`` marker).
"""

from __future__ import annotations

import os
import shlex
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

from mtmetrology.cli._common import fail
from mtmetrology.io.files import write_json

__all__ = ["DemoContext", "DemoSection", "demo"]

#: Marks a folder written by ``mtm demo`` (and so safe to replace).
MARKER = ".mtm-demo"
DEFAULT_SEED = 2026


@dataclass
class DemoContext:
    """What a section needs: where to write, the report, the seed, the console.

    Attributes
    ----------
    out : Path
        The demo folder as the user will find it (commands are printed with it).
    work : Path
        Where files are written during the run (renamed to ``out`` at the end).
    report : mtmetrology.report.Report
        The demo's report; each section adds its sections to it.
    seed : int
        Root seed; sections derive their streams from it.
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

    def command(self, purpose: str, *argv: str) -> None:
        """Print ``$ mtm ...`` (a step the user can redo) and list it in the report."""
        line = shlex.join(["mtm", *argv])
        self.commands.append((purpose, line))
        self.console.print(f"  [dim]{purpose}:[/dim] $ {line}", soft_wrap=True)

    @contextmanager
    def step(self, description: str) -> Iterator[None]:
        """A progress line (spinner, bar, elapsed time) around one step of a section."""
        task = self.progress.add_task(description, total=1)
        yield
        self.progress.update(task, completed=1)


@dataclass(frozen=True)
class DemoSection:
    """One part of the demo: a short name, the title printed above it, its function."""

    name: str
    title: str
    run: Callable[[DemoContext], None]


def _umask() -> int:
    """The process umask (read by setting it and restoring it at once)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _prepare(out: Path) -> Path:
    """A fresh work folder beside ``out``; refuse to replace a folder the demo did not write."""
    if out.exists() and not (out / MARKER).exists():
        fail(f"{out} exists and is not a demo folder; choose another --out")
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


def demo(
    ctx: typer.Context,
    out: Annotated[Path, typer.Option("--out", help="Folder to write the demo into.")] = Path(
        "mtm-demo"
    ),
    seed: Annotated[int, typer.Option(help="Root seed of every simulation.")] = DEFAULT_SEED,
) -> None:
    """Run the engines end to end on built-in virtual machines and write a report.

    A simulated SAMBA campaign calibrated with GUF and adaptive Monte Carlo (JCGM 102
    validation), a gauge block before and after compensation, its task uncertainty and
    ISO 14253-1 decision, compensated coordinates, GUM H.1 by GUF and adaptive Monte
    Carlo, a sphere fit, a bridge CMM calibrated on a ball plate and
    compared with a GP error model: input files, JSON results, report.html, and the
    commands that redo each step.
    """
    from mtmetrology.cli._common import command_line
    from mtmetrology.cli.demo_sections import DEMO_SECTIONS
    from mtmetrology.report import Report

    work = _prepare(out)
    console = Console()
    report = Report(
        "mtmetrology demo",
        command=command_line(ctx),
        provenance={"seed": seed, "folder": str(out)},
    )
    columns = (SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn())
    try:
        with Progress(*columns, console=console) as progress:
            context = DemoContext(out, work, report, seed, console, progress)
            for section in DEMO_SECTIONS:
                progress.console.rule(f"[bold]{section.title}")
                section.run(context)
        _commands_section(context)
        report.write(work / "report.html")
        _publish(work, out)
    except KeyboardInterrupt:
        shutil.rmtree(work, ignore_errors=True)
        typer.echo("interrupted: nothing written", err=True)
        raise typer.Exit(code=130) from None
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    console.rule("[bold]Summary")
    for line in context.summary:
        console.print(f"- {line}")
    console.print(f"inputs, JSON results and the commands' files: {out}/")
    console.print(f"[bold]report: {out / 'report.html'}[/bold]")
