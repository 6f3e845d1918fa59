"""The progress bar of long commands (mtmetrology.cli._progress): drawn on a terminal
only, and only once the run has lasted 2 s."""

from __future__ import annotations

import io

from rich.console import Console

from mtmetrology.cli._progress import progress_bar


class _Clock:
    def __init__(self):
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def _console(terminal: bool) -> tuple[Console, io.StringIO]:
    out = io.StringIO()
    return Console(file=out, force_terminal=terminal, width=80), out


def test_on_a_terminal_the_bar_appears_after_two_seconds_only():
    console, out = _console(terminal=True)
    clock = _Clock()
    with progress_bar("pooling draws", console=console, clock=clock) as progress:
        clock.now += 1.9
        progress(1, 10)
        assert out.getvalue() == ""  # a short run prints nothing
        clock.now += 0.2
        progress(2, 10)
        progress(10, 10)
    assert "pooling draws" in out.getvalue() and "10/10" in out.getvalue()


def test_not_on_a_terminal_nothing_is_drawn_however_long():
    """Off a terminal there is no callback: the library runs as without a display."""
    console, out = _console(terminal=False)
    clock = _Clock()
    with progress_bar("pooling draws", console=console, clock=clock) as progress:
        clock.now += 50.0
        assert progress is None
    assert out.getvalue() == ""


def test_a_run_without_a_known_end_counts_its_trials():
    """An adaptive Monte Carlo (total None): the bar shows the trials done, of no total."""
    console, out = _console(terminal=True)
    clock = _Clock()
    with progress_bar("Monte Carlo trials", console=console, clock=clock) as progress:
        clock.now += 2.5
        progress(30_000, None)
        progress(870_000, None)
    assert "Monte Carlo trials" in out.getvalue() and "870000/?" in out.getvalue()


def test_a_monte_carlo_command_draws_its_trials_on_a_terminal(monkeypatch):
    """``mtm uncertainty run --method mcm``: on a (fake) terminal whose (fake) clock passes
    5 s per reading, the bar counts the trials up to the total."""
    from pathlib import Path

    from typer.testing import CliRunner

    import mtmetrology.cli._progress as progress_module
    from mtmetrology.cli import build_app

    console, out = _console(terminal=True)
    clock = _Clock()

    def ticking() -> float:
        clock.now += 5.0
        return clock.now

    real = progress_module.progress_bar
    monkeypatch.setattr(
        "mtmetrology.cli.uncertainty.progress_bar",
        lambda description: real(description, console=console, clock=ticking),
    )
    model = Path(__file__).resolve().parents[2] / "examples" / "gum-h1-end-gauge.yaml"
    result = CliRunner().invoke(
        build_app("uncertainty"),
        ["uncertainty", "run", str(model), "--method", "mcm", "--trials", "20000", "--seed", "1"],
    )
    assert result.exit_code == 0, result.output
    assert "Monte Carlo trials" in out.getvalue() and "20000/20000" in out.getvalue()
