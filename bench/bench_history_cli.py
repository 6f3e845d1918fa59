"""Benchmark: ``mtm history list``, ``show`` and ``add`` on a one-run SQLite database at
the current schema, in fresh processes (issue 32).

Issue 32 measured ``mtm history list`` at 1.6 s wall and 150 MiB (median of 5): every
command imported the drift model, SciPy and Alembic and ran the migration check under the
write lock. Target: list, show and add within 3x of ``python -c "import numpy"`` (the floor:
no command starts without numpy); the revision is checked with one SELECT and Alembic runs
only when it differs.

Contenders, each a fresh interpreter timed over 5 repeats (min and median), with the peak
resident set of the child (``VmHWM``):

- ours: ``mtm history list``, ``mtm history show 1``, ``mtm history add`` of one new
  calibration (a new document each repeat: the same one is refused as recorded), and
  ``mtm history add`` of 16 calibrations in one call (one transaction);
- baseline: ``mtm --help`` (the command line's own start-up);
- floor: ``python -c "import numpy"`` (first: the yardstick); second, ``import
  sqlalchemy.orm`` (the database layer list, show and add imported before they ran on
  :mod:`sqlite3`; the other history commands still import it).

Result (2026-11-28, 2 cores): list, show and add on a SQLite file at the current schema run
on :mod:`sqlite3` and import no SQLAlchemy (mtmetrology.history.sql); before, ``import
sqlalchemy`` alone was about twice the numpy floor. RESULTS.md holds the run of 04:04 UTC
(load average 0.6), median (min) over the numpy floor's median 0.101 s (min 0.091 s):
``list`` 0.221 s (0.217 s), 2.2x, **met**; ``show 1`` 0.234 s (0.228 s), 2.3x, **met**;
``add`` of 1 file 0.364 s (0.357 s), 3.6x, **missed**; of 16 files 0.399 s (0.389 s), 4.0x,
**missed** (three earlier runs under load: list 2.0-2.4x, show 2.6-3.2x, add 3.3-4.6x).
Peak RSS: list and show 35 MiB (was 56 and 69), add 82 MiB. What add costs over list,
0.14 s, measured in the process: numpy (about 0.08 s, with OpenBLAS starting its threads:
add's CPU seconds exceed its wall time), the machine's definition (YAML, its pydantic
models, the kinematics modules: about 0.06 s), ``Machine.load`` 8 ms and the database work
12 ms (16 files: a few ms more). Every command also pays typer's start-up (``mtm --help``
0.17 s, 1.7x the floor) and, when it runs, typer 0.29's option conversion, which imports
pydantic and builds a TypeAdapter for each option (``add`` has 13). So add, which needs
what list needs and numpy (the check of a calibration is arithmetic on its parameter
vector), is at 2.2x + 0.8x = 3.0x before it reads the machine's definition. Tried and
dropped: typer 0.28 (before the pydantic conversion) put first on the path gave add no
gain (0.46 / 0.54 s against 0.45 / 0.49 s, min / median of 8, alternating; pydantic is
imported by the machine definition's models all the same). What remains is building the
kinematic chain at load (its modules and the optimiser's, about 0.035 s, could be imported
on first evaluation), not enough alone for 3x. The numpy + SQLAlchemy ORM floor (0.44 s)
is above every command.

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
    """``mtm history add`` of ``n`` new documents, written before each run (not timed
    apart: writing a 3 kB file is microseconds next to a process start)."""

    def __init__(self, db: Path, documents: Documents, n: int):
        super().__init__([])
        self.db, self.documents, self.n = db, documents, n

    def __call__(self) -> None:
        self.args = [*MTM, "history", "add", *self.documents.write(self.n), "--db", str(self.db)]
        super().__call__()


def main() -> None:
    bench = Benchmark("history_cli", "fresh interpreter, mtm history on a one-run SQLite file")
    with tempfile.TemporaryDirectory() as tmp:
        directory = Path(tmp)
        documents = Documents(directory)
        one = directory / "one.sqlite"
        Adding(one, documents, 1)()  # the database, at the current schema, with one run
        floor = Child(FLOOR)
        bench.time('python -c "import numpy"', "floor", floor)
        bench.timings[-1].note = floor.note()
        orm = Child(ORM_FLOOR)
        bench.time("import numpy, sqlalchemy.orm", "floor", orm)
        bench.timings[-1].note = orm.note()
        children = {
            "mtm --help": Child([*MTM, "--help"]),
            "mtm history list": Child([*MTM, "history", "list", "--db", str(one)]),
            "mtm history show 1": Child([*MTM, "history", "show", "1", "--db", str(one)]),
            "mtm history add (1 file)": Adding(directory / "add.sqlite", documents, 1),
            f"mtm history add ({BATCH} files)": Adding(
                directory / "batch.sqlite", documents, BATCH
            ),
        }
        for label, child in children.items():
            bench.time(label, "baseline" if label == "mtm --help" else "ours", child)
            bench.timings[-1].note = child.note()
            if label != "mtm --help":
                bench.target(label, 3.0, relative_to='python -c "import numpy"')
        for label, child in children.items():
            ratio = min(child.cpu) / min(floor.cpu)
            bench.notes.append(
                f"CPU {label}: {ratio:.1f}x the numpy floor's ({'met' if ratio <= 3 else 'over'}"
                f" 3x), {min(child.cpu) / min(orm.cpu):.1f}x numpy + sqlalchemy.orm"
            )
        bench.notes.append(json.dumps({"batch": BATCH}))
        bench.report()


if __name__ == "__main__":
    main()
