"""A progress bar for long library calls: on a terminal, and only once the run is long.

The library reports progress through a plain callback ``progress(done, total)`` (total None
when the run decides its own end, as an adaptive Monte Carlo does) and knows nothing of the
display; :func:`progress_bar` gives such a callback that draws a rich bar
on standard error when standard error is a terminal and the call has already run for
``after`` seconds (2 s: a short run prints nothing). Not on a terminal (a pipe, a file, a
CI log) it gives no callback (None) and draws nothing, so standard error stays the messages
and the library runs as it does without a display.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

__all__ = ["progress_bar"]


@contextmanager
def progress_bar(
    description: str,
    *,
    after: float = 2.0,
    console=None,
    clock: Callable[[], float] = time.monotonic,
) -> Iterator[Callable[[int, int | None], None] | None]:
    """A ``progress(done, total)`` callback drawing a transient bar once ``after`` s passed.

    Parameters
    ----------
    description : str
        Shown left of the bar.
    after : float
        Seconds of run before the bar appears.
    console : rich.console.Console, optional
        Where to draw (default: standard error); nothing is drawn unless it is a terminal.
    clock : callable
        Seconds, monotonic (a test passes its own).

    Yields
    ------
    callable or None
        ``progress(done, total)``; ``total`` None draws a bar without an end ("done/?").
        None when ``console`` is not a terminal: the library then runs as without a
        display (a Monte Carlo evaluates its chunks in one pass, not in reporting rounds).
    """
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeRemainingColumn,
    )

    console = Console(stderr=True) if console is None else console
    if not console.is_terminal:
        yield None
        return
    start = clock()
    shown: list = []  # [Progress, task id] once drawn

    def progress(done: int, total: int | None) -> None:
        if not shown:
            if clock() - start < after:
                return
            bar = Progress(
                TextColumn(description),
                BarColumn(),
                MofNCompleteColumn(),
                TimeRemainingColumn(),
                console=console,
                transient=True,
            )
            bar.start()
            shown.extend([bar, bar.add_task(description, total=total)])
        shown[0].update(shown[1], completed=done, total=total)

    try:
        yield progress
    finally:
        if shown:
            shown[0].stop()
