"""Benchmark: start-up of the command line, each command's ``--help`` and ``mtm machine
list``, in fresh processes.

Issue 20 target: every command's start-up within 3x of ``python -c "import numpy"`` (the
floor: no command can start without numpy); a command imports only what it runs.

Contenders, each a fresh interpreter timed over 5 repeats (min and median), with the peak
resident set of the child (``VmHWM``):

- ours: ``mtm --help``, ``mtm machine list`` and ``mtm <command> --help`` for every
  command, as the console script runs them;
- baseline: ``mtm --help`` with every command module imported (what the listing cost
  before the summaries: the whole command line built);
- floor: ``python -c "import numpy"``; second, Typer's own help machinery
  (``typer.rich_utils`` and pydantic, which Typer 0.29 imports to build every parameter's
  adapter): what any ``mtm <command> --help`` pays before it imports a module of ours;
  third, a bare Typer group's ``--help`` (five commands of three parameters, nothing of
  ours): the help of a group of subcommands, which ``mtm machine --help`` is, rendered
  by Typer alone.

Run: ``python bench/bench_startup.py`` (``make bench``).  On a shared host the wall
times mostly measure the other processes: the notes give each command's CPU seconds (user
+ system, least of the repeats) over the floor's, the ratio that load does not inflate.
"""

from __future__ import annotations

import sys

from bench_csv import MTM, OWN_PEAK, Child
from harness import Benchmark
from mtmetrology.cli import COMMANDS, SHARED_GROUPS

FLOOR = [sys.executable, "-c", f"{OWN_PEAK}; import numpy"]
TYPER_FLOOR = [sys.executable, "-c", f"{OWN_PEAK}; import typer.rich_utils, pydantic"]
#: A Typer group of five commands (an argument and two options each), its --help.
TYPER_GROUP = (
    "from typing import Annotated\n"
    "import typer\n"
    "app, group = typer.Typer(), typer.Typer(help='A group.')\n"
    "def command(name: Annotated[str, typer.Argument(help='a')],\n"
    "            model: Annotated[str | None, typer.Option(help='b')] = None,\n"
    "            json: Annotated[bool, typer.Option(help='c')] = False) -> None:\n"
    "    'A command.'\n"
    "for i in range(5):\n"
    "    group.command(f'c{i}')(command)\n"
    "app.add_typer(group, name='group')\n"
    "app.callback()(lambda: None)\n"
    "app(['group', '--help'], prog_name='mtm', standalone_mode=False)\n"
)
TYPER_GROUP_HELP = [sys.executable, "-c", f"{OWN_PEAK}\n{TYPER_GROUP}"]
#: The whole command line built, then its listing (the cost before the summaries).
FULL_HELP = [
    sys.executable,
    "-c",
    f"{OWN_PEAK}; from mtmetrology.cli import build_app; "
    "build_app()(['--help'], standalone_mode=False)",
]


def main() -> None:
    bench = Benchmark("startup", "fresh interpreter, command-line start-up to exit")
    floor = Child(FLOOR)
    bench.time('python -c "import numpy"', "floor", floor)
    bench.timings[-1].note = floor.note()
    typer_floor = Child(TYPER_FLOOR)
    bench.time("Typer's help machinery (rich, pydantic)", "floor", typer_floor)
    bench.timings[-1].note = typer_floor.note()
    typer_group = Child(TYPER_GROUP_HELP)
    bench.time("a bare Typer group's --help (5 commands)", "floor", typer_group)
    bench.timings[-1].note = typer_group.note()
    children = {}
    runs = [("mtm --help", ["--help"]), ("mtm machine list", ["machine", "list"])]
    runs += [(f"mtm {c} --help", [c, "--help"]) for c in [*COMMANDS, *SHARED_GROUPS]]
    for label, args in runs:
        child = children[label] = Child([*MTM, *args])
        bench.time(label, "ours", child)
        bench.timings[-1].note = child.note()
        bench.target(label, 3.0, relative_to='python -c "import numpy"')
    full = Child(FULL_HELP)
    bench.time("mtm --help, every command imported", "baseline", full)
    bench.timings[-1].note = full.note()
    children["mtm --help, every command imported"] = full
    for label, child in children.items():
        ratio = min(child.cpu) / min(floor.cpu)
        bench.notes.append(
            f"CPU {label}: {ratio:.1f}x the floor's ({'met' if ratio <= 3 else 'over'} 3x), "
            f"{min(child.cpu) / min(typer_floor.cpu):.1f}x Typer's help machinery, "
            f"{min(child.cpu) / min(typer_group.cpu):.1f}x a bare Typer group's --help"
        )
    bench.report()


if __name__ == "__main__":
    main()
