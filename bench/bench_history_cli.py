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

Result (2026-11-28, 2 shared cores, three runs; RESULTS.md holds the last): list, show
and add on a SQLite file at the current schema now run on :mod:`sqlite3` and import no
SQLAlchemy (mtmetrology.history.sql); before, ``import sqlalchemy`` alone was about twice
the numpy floor. The last run, median (min) over the numpy floor's median 0.109 s (min
0.097 s): ``list`` 0.260 s (0.218 s), 2.4x, **met** (2.0x and 2.1x in the two earlier
runs); ``show 1`` 0.281 s (0.244 s), 2.6x, **met** (2.8x and 3.2x before ``units`` stopped
importing numpy); ``add`` of 1 file 0.500 s (0.407 s), 4.6x, **missed** (3.4x and 3.5x in
the earlier runs), of 16 files 0.428 s (0.360 s), 3.9x, **missed** (4.3x, 3.3x). CPU
seconds over the floor's: list 2.3x, show 2.5x, add 3.6-4.2x. What add still costs over
list is numpy and the machine model (a calibration is checked against the machine's
definition: ``Machine.load``, ``ParameterSet.from_document``), about 0.14 s; the database
work of 16 files is a few milliseconds. The numpy + SQLAlchemy ORM floor (0.44 s) is now
above every command. Part of every command's start-up is typer's own (``mtm --help``
0.18 s; typer 0.29 imports pydantic to convert each option when a command runs).

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
