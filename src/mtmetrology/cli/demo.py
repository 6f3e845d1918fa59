"""``mtm demo``: the example scripts of ``examples/`` end to end, no input files.

The demo runs the scripts listed in :data:`mtmetrology.report.demo.EXAMPLES` in order
(:func:`mtmetrology.report.demo.run_demo`): each makes its input files, computes its
results with the library, writes them as JSON/CSV, adds its part to one HTML report and
prints the ``mtm`` commands that redo its steps. Each script also runs on its own
(``python examples/samba_calibration.py``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from mtmetrology.report.demo import DEFAULT_SEED, run_demo

__all__ = ["demo"]


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
    commands that redo each step. The steps are the scripts of ``examples/``.
    """
    from mtmetrology.cli._common import command_line

    try:
        run_demo(out, seed, command=command_line(ctx))
    except KeyboardInterrupt:
        typer.echo("interrupted: nothing written", err=True)
        raise typer.Exit(code=130) from None
