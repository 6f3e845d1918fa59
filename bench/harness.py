"""One way to time and report every benchmark in bench/.

A benchmark times, in one run, each contender over at least 5 repeats and prints min and
median: ours, the strongest honest baseline (vectorised numpy written in the benchmark),
a per-trial loop or peer library where one applies, and the hardware floor (writing the
output once, drawing the random inputs).  Ratios are taken on the median against *ours*
(``x`` > 1: ours is faster) and against the floor (ours / floor: how far from the
hardware limit; the *first* floor listed is the yardstick, so list the floor the target
is stated against first).  Targets are stated once and printed as met or missed; a benchmark never
fails a test run.

Each benchmark also leaves a JSON fragment in ``bench/results/`` that
``python bench/run_all.py`` (``make bench``) gathers into ``bench/RESULTS.md`` with the
machine, the library versions and the date.

Examples
--------
>>> import numpy as np
>>> b = Benchmark("demo", "sum of 10^5 numbers")
>>> x = np.ones(100_000)
>>> _ = b.time("ours", "ours", x.sum, repeats=5)
>>> _ = b.time("write floor", "floor", lambda: np.empty_like(x).fill(0.0), repeats=5)
>>> b.timings[0].repeats
5
"""

from __future__ import annotations

import json
import statistics
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

__all__ = ["KINDS", "Benchmark", "Target", "Timing", "patched", "repeat_times"]

RESULTS_DIR = Path(__file__).resolve().parent / "results"
#: ours, a vectorised baseline, a per-trial loop (timed on a subset, extrapolated), a peer
#: library, and the hardware floor.
KINDS = ("ours", "baseline", "loop", "peer", "floor")


def patched(owner: object, attribute: str, value: object, function: Callable[[], object]):
    """``function`` made to run with ``owner.attribute`` set to ``value``, restored after
    (e.g. a module's ``BACKEND``, to time one implementation against another)."""

    def run():
        saved = getattr(owner, attribute)
        setattr(owner, attribute, value)
        try:
            return function()
        finally:
            setattr(owner, attribute, saved)

    return run


def repeat_times(function: Callable[[], object], repeats: int = 5, warmup: int = 1) -> list:
    """Wall-clock seconds of ``repeats`` calls after ``warmup`` untimed ones."""
    if repeats < 5:
        raise ValueError(f"at least 5 repeats are needed for a min and a median, got {repeats}")
    for _ in range(warmup):
        function()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return times


@dataclass
class Timing:
    """Times of one contender (seconds), scaled when it ran on a subset."""

    label: str
    kind: str
    times: list
    scale: float = 1.0
    note: str = ""

    @property
    def repeats(self) -> int:
        return len(self.times)

    @property
    def min(self) -> float:
        return min(self.times) * self.scale

    @property
    def median(self) -> float:
        return statistics.median(self.times) * self.scale


@dataclass
class Target:
    """A stated target: ``label`` (median seconds) must be below ``limit`` seconds, or, when
    ``relative_to`` is given, below ``limit`` times that contender's median."""

    label: str
    limit: float
    relative_to: str | None = None
    text: str = ""


@dataclass
class Benchmark:
    """Timings of one benchmark problem, printed as one table."""

    name: str
    problem: str
    timings: list = field(default_factory=list)
    targets: list = field(default_factory=list)
    notes: list = field(default_factory=list)

    def time(
        self,
        label: str,
        kind: str,
        function: Callable[[], object],
        *,
        repeats: int = 5,
        warmup: int = 1,
        scale: float = 1.0,
        note: str = "",
    ) -> Timing:
        """Time ``function`` and record it.  ``scale`` extrapolates a subset run (e.g. a
        per-trial loop timed on 1 % of the trials gets ``scale=100``)."""
        if kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {kind!r}")
        timing = Timing(label, kind, repeat_times(function, repeats, warmup), scale, note)
        self.timings.append(timing)
        return timing

    def time_interleaved(
        self, contenders: list, *, repeats: int = 5, warmup: int = 1
    ) -> list[Timing]:
        """Time several contenders in alternation (a, b, c, a, b, c, ...) and record each,
        so that a change of load on a shared machine hits all of them alike.
        ``contenders``: tuples ``(label, kind, function)`` or ``(label, kind, function,
        note)``."""
        if repeats < 5:
            raise ValueError(f"at least 5 repeats are needed for a min and a median, got {repeats}")
        for c in contenders:
            if c[1] not in KINDS:
                raise ValueError(f"kind must be one of {KINDS}, got {c[1]!r}")
        for _ in range(warmup):
            for c in contenders:
                c[2]()
        times: list[list[float]] = [[] for _ in contenders]
        for _ in range(repeats):
            for c, out in zip(contenders, times, strict=True):
                start = time.perf_counter()
                c[2]()
                out.append(time.perf_counter() - start)
        recorded = [
            Timing(c[0], c[1], t, 1.0, c[3] if len(c) > 3 else "")
            for c, t in zip(contenders, times, strict=True)
        ]
        self.timings.extend(recorded)
        return recorded

    def target(self, label: str, limit: float, relative_to: str | None = None, text: str = ""):
        self.targets.append(Target(label, limit, relative_to, text))

    def _get(self, label: str) -> Timing:
        for t in self.timings:
            if t.label == label:
                return t
        raise KeyError(f"no timing labelled {label!r}")

    def target_results(self) -> list[tuple[Target, float, bool]]:
        out = []
        for tg in self.targets:
            value = self._get(tg.label).median
            if tg.relative_to is not None:
                value = value / self._get(tg.relative_to).median
            out.append((tg, value, value <= tg.limit))
        return out

    def table(self) -> str:
        """The printed table: min, median, and ratios to ours and to the floor."""
        ours = next((t for t in self.timings if t.kind == "ours"), None)
        floor = next((t for t in self.timings if t.kind == "floor"), None)
        head = f"{'contender':<46}{'kind':<9}{'min (s)':>10}{'median (s)':>12}{'vs ours':>10}"
        head += f"{'/ floor':>9}"
        lines = [f"== {self.name}: {self.problem}", head]
        for t in self.timings:
            vs = f"{t.median / ours.median:9.2f}x" if ours and t is not ours else " " * 10
            fl = f"{t.median / floor.median:8.2f}x" if floor and t.kind != "floor" else " " * 9
            extra = f"  ({t.note})" if t.note else ""
            lines.append(f"{t.label:<46}{t.kind:<9}{t.min:>10.4f}{t.median:>12.4f}{vs}{fl}{extra}")
        for tg, value, met in self.target_results():
            unit = "x" if tg.relative_to else " s"
            ref = f" of {tg.relative_to}" if tg.relative_to else ""
            lines.append(
                f"target: {tg.label} <= {tg.limit:g}{unit}{ref}: "
                f"{value:.3g}{unit} -> {'met' if met else 'MISSED'}"
                + (f"  [{tg.text}]" if tg.text else "")
            )
        lines.extend(f"note: {n}" for n in self.notes)
        return "\n".join(lines)

    def report(self, write: bool = True) -> None:
        """Print the table and leave the JSON fragment for ``bench/RESULTS.md``."""
        print(self.table(), flush=True)
        if write:
            RESULTS_DIR.mkdir(exist_ok=True)
            doc = {
                "name": self.name,
                "problem": self.problem,
                "timings": [{**asdict(t), "min": t.min, "median": t.median} for t in self.timings],
                "targets": [
                    {**asdict(tg), "value": value, "met": met}
                    for tg, value, met in self.target_results()
                ],
                "notes": self.notes,
            }
            (RESULTS_DIR / f"{self.name}.json").write_text(json.dumps(doc, indent=2) + "\n")
