"""Benchmark: ``mtm history list``, ``show`` and ``add`` on a one-run SQLite database at
the current schema, in fresh processes (issue 32).

Issue 32 measured ``mtm history list`` at 1.6 s wall and 150 MiB (median of 5): every
command imported the drift model, SciPy and Alembic and ran the migration check under the
write lock. Target: list, show and add within 3x of ``python -c "import numpy"`` (the floor:
no command starts without numpy); the revision is checked with one SELECT and Alembic runs
only when it differs.

Contenders, each a fresh interpreter, timed in alternation (a, b, c, a, b, c, ...: a change
of load on the shared host hits all alike) over 9 repeats after one uncounted round (min
and median), with the peak resident set of the child (``VmHWM``):

- ours: ``mtm history list``, ``mtm history show 1``, ``mtm history add`` of one new
  calibration (a new document each repeat, all written before the timing: the same one is
  refused as recorded), and
  ``mtm history add`` of 16 calibrations in one call (one transaction);
- baseline: ``mtm --help`` (the command line's own start-up);
- floor: ``python -c "import numpy"`` (first: the yardstick); second, ``import
  sqlalchemy.orm`` (the database layer list, show and add imported before they ran on
  :mod:`sqlite3`; the other history commands still import it).

Result (2026-11-28, 2 cores): list, show and add on a SQLite file at the current schema run
on :mod:`sqlite3` and import no SQLAlchemy (mtmetrology.history.sql); before, ``import
sqlalchemy`` alone was about twice the numpy floor. RESULTS.md holds the run of 04:29 UTC
(load average 1.5; in alternation), median (min) over the numpy floor's median 0.091 s
(min 0.081 s): ``list`` 0.190 s (0.184 s), 2.1x, **met**; ``show 1`` 0.195 s (0.184 s),
2.1x, **met**; ``add`` of 1 file 0.304 s (0.291 s), 3.3x, **missed**; of 16 files 0.323 s
(0.308 s), 3.5x, **missed**. (Earlier runs in blocks, one contender's repeats after
another's: list 2.0-2.4x, show 2.3-3.2x, add 3.3-4.6x.) Peak RSS: list and show 33-34 MiB
(were 56 and 69), add 82 MiB.

Where add's time goes, measured in the process (one file, ms from the interpreter's
start): the command line (typer) 49; the imports add needs beyond it, 150 (numpy about 65,
pydantic with its plugin discovery about 45, YAML 17, the machine definition's pydantic
models and the kinematics modules about 25); typer's conversion of the 13 options (a
pydantic TypeAdapter each, typer 0.29) 21; reading the document 0.6, ``Machine.load`` 8, the
database work 6.5 (16 files: a few ms more); then about 45 ms of interpreter start and exit
(the exit's garbage collection of 40 000 objects alone 10-13 ms). Every part but the last
three is an import or a start-up of a dependency the command cannot do without: numpy
(the check of a calibration is arithmetic on its parameter vector), the machine's
definition (YAML validated by pydantic models) and typer. Tried and dropped: typer 0.28
(before the pydantic conversion) first on the path: no gain for add (0.46 / 0.54 s against
0.45 / 0.49 s, min / median of 8 in alternation on a busier host; pydantic is imported by
the machine definition's models all the same); importing the kinematic chain and the
optimiser only on first evaluation: the machine module adds 0-10 ms over its definition,
within the noise; ``PYDANTIC_DISABLE_PLUGINS``: 7 ms. The numpy + SQLAlchemy ORM floor
(0.38 s) is above every command.

Run: ``python bench/bench_history_cli.py``. On a shared host the wall times mostly measure
the other processes: the notes give each command's CPU seconds (user + system, least of
the repeats) over the floor's, the ratio that load does not inflate.
"""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import numpy as np

from bench_csv import MTM, OWN_PEAK, Child
from harness import Benchmark
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

FLOOR = [sys.executable, "-c", f"{OWN_PEAK}; import numpy"]
ORM_FLOOR = [sys.executable, "-c", f"{OWN_PEAK}; import numpy, sqlalchemy.orm"]
MACHINE = Machine.load("five-axis-wcbxfzyst")
BATCH = 16
#: Repeats of each contender (in alternation), after one uncounted round.
REPEATS = 9
WARMUP = 1


class Documents:
    """New calibration documents of MACHINE (distinct values: none is a duplicate)."""

    def __init__(self, directory: Path, seed: int = 32):
        self.directory = directory
        self.rng = np.random.default_rng(seed)
        self.count = 0

    def write(self, n: int = 1) -> list[str]:
        paths = []
        for _ in range(n):
            self.count += 1
            path = self.directory / f"cal{self.count}.json"
            values = self.rng.normal(size=13) * MACHINE.parameter_scales
            ParameterSet(
                MACHINE.parameter_names,
                values,
                MACHINE.parameter_units,
                np.diag((0.5 * MACHINE.parameter_scales) ** 2),
                machine=MACHINE.name,
                model="13",
            ).save(path)
            paths.append(str(path))
        return paths


class Adding(Child):
    """``mtm history add`` of ``n`` new documents a call, all written before the timing
    starts (one set per call: the same document twice is refused as recorded)."""

    def __init__(self, db: Path, documents: Documents, n: int, calls: int):
        super().__init__([])
        self.db = db
        self.batches = [documents.write(n) for _ in range(calls)]

    def __call__(self) -> None:
        self.args = [*MTM, "history", "add", *self.batches.pop(0), "--db", str(self.db)]
        super().__call__()


def main() -> None:
    bench = Benchmark("history_cli", "fresh interpreter, mtm history on a one-run SQLite file")
    with tempfile.TemporaryDirectory() as tmp:
        directory = Path(tmp)
        documents = Documents(directory)
        one = directory / "one.sqlite"
        Adding(one, documents, 1, 1)()  # the database, at the current schema, with one run
        calls = WARMUP + REPEATS
        floor = Child(FLOOR)
        children = {
            'python -c "import numpy"': ("floor", floor),
            "import numpy, sqlalchemy.orm": ("floor", Child(ORM_FLOOR)),
            "mtm --help": ("baseline", Child([*MTM, "--help"])),
            "mtm history list": ("ours", Child([*MTM, "history", "list", "--db", str(one)])),
            "mtm history show 1": ("ours", Child([*MTM, "history", "show", "1", "--db", str(one)])),
            "mtm history add (1 file)": (
                "ours",
                Adding(directory / "add.sqlite", documents, 1, calls),
            ),
            f"mtm history add ({BATCH} files)": (
                "ours",
                Adding(directory / "batch.sqlite", documents, BATCH, calls),
            ),
        }
        # in alternation, so that a change of load on the shared host hits all alike
        bench.time_interleaved(
            [(label, kind, child) for label, (kind, child) in children.items()],
            repeats=REPEATS,
            warmup=WARMUP,
        )
        for timing in bench.timings:
            timing.note = children[timing.label][1].note()
            if timing.kind == "ours":
                bench.target(timing.label, 3.0, relative_to='python -c "import numpy"')
        orm = children["import numpy, sqlalchemy.orm"][1]
        for label, (kind, child) in children.items():
            if kind == "floor":
                continue
            ratio = min(child.cpu) / min(floor.cpu)
            bench.notes.append(
                f"CPU {label}: {ratio:.1f}x the numpy floor's ({'met' if ratio <= 3 else 'over'}"
                f" 3x), {min(child.cpu) / min(orm.cpu):.1f}x numpy + sqlalchemy.orm"
            )
        bench.notes.append(json.dumps({"batch": BATCH}))
        bench.report()


if __name__ == "__main__":
    main()
