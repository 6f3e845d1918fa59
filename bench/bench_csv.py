"""Benchmark: 1 M-row CSV records through ``mtm predict`` and ``mtm fit sphere``.

Issue 9 target: one million rows read, computed and written in under 3 s and under
300 MB of peak resident memory (the whole process, start-up included).

Contenders, each timed over 5 repeats (min and median), with the peak resident set size
of each child process (its own ``VmHWM``, reported at exit):

- ours: the real command line in a fresh process, as its console script runs it (``mtm
  predict ... -o out.csv``, ``mtm fit sphere points.csv --json``): imports, strict reading,
  the travel checks, the kinematic chain in chunks, vectorised writing, ``fsync``;
- ours, in process: the same steps without interpreter start-up and imports;
- baseline: the vectorised numpy way without pandas: ``numpy.loadtxt``, the same
  :meth:`Machine.forward`, ``numpy.savetxt`` (for fit: ``loadtxt`` and the same fit);
- floor: writing the complete output once (predict) or reading the file once (fit).

Run: ``python bench/bench_csv.py`` (``make bench``).  Numbers depend on the load of the
machine: on a shared host compare the ratios, and the CPU seconds printed with the RSS.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from harness import Benchmark
from mtmetrology.fitting.least_squares import fit_sphere
from mtmetrology.io import atomic_write, read_csv_table, write_columns
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.readings_table import readings_from_table

ROWS = 1_000_000
SRC = str(Path(__file__).resolve().parents[1] / "src")
#: At exit, the process's own peak resident set (``VmHWM``, kB) into ``$MTM_BENCH_PEAK``.
#: ``ru_maxrss`` from ``wait4`` would not do: Linux carries the peak of the memory the
#: child had before ``exec`` — for a (v)forked child, that of this large benchmark process.
OWN_PEAK = (
    "import atexit, os; atexit.register(lambda: open(os.environ['MTM_BENCH_PEAK'], 'w')"
    ".write(next(x for x in open('/proc/self/status') if x.startswith('VmHWM:')).split()[1]))"
)
#: ``mtm`` as its console script runs it (plus the peak report above).
MTM = [sys.executable, "-c", f"{OWN_PEAK}; from mtmetrology.__main__ import main; main()"]
MACHINE = "five-axis-wcbxfzyst"


def make_files(directory: Path) -> tuple[Path, Path]:
    """1 M probing records (X, Y, Z, B, C within the travels) and 1 M sphere points."""
    rng = np.random.default_rng(9)
    records = directory / "records.csv"
    q = {
        "X": rng.uniform(-200, 200, ROWS),
        "Y": rng.uniform(-150, 150, ROWS),
        "Z": rng.uniform(-100, 200, ROWS),
        "B": rng.uniform(-90, 90, ROWS),
        "C": rng.uniform(0, 360, ROWS),
    }
    with atomic_write(records, "wb") as fh:
        write_columns(fh, q, decimals=4)
    u = rng.normal(size=(ROWS, 3))
    p = 12.5 * u / np.linalg.norm(u, axis=1, keepdims=True) + (1.0, -2.0, 3.0)
    p += rng.normal(scale=1e-3, size=p.shape)
    points = directory / "points.csv"
    with atomic_write(points, "wb") as fh:
        write_columns(fh, {"x": p[:, 0], "y": p[:, 1], "z": p[:, 2]}, decimals=6)
    return records, points


class Child:
    """Run a command in a fresh process; keep the largest peak RSS and CPU seconds seen."""

    def __init__(self, args: list[str]):
        self.args = args
        self.peak_kib = 0  # VmHWM is in KiB ("kB" in /proc)
        self.cpu = []

    def __call__(self) -> None:
        peak_file = Path(tempfile.mkdtemp()) / "peak"
        env = {**os.environ, "PYTHONPATH": SRC, "MTM_BENCH_PEAK": str(peak_file)}
        with open(os.devnull, "wb") as null:
            p = subprocess.Popen(self.args, env=env, stdout=null, stderr=subprocess.PIPE)
            _, status, usage = os.wait4(p.pid, 0)
            p.returncode = os.waitstatus_to_exitcode(status)
            err = p.stderr.read().decode()
            p.stderr.close()
        if p.returncode != 0:
            raise RuntimeError(f"{self.args}: exit {p.returncode}: {err}")
        self.peak_kib = max(self.peak_kib, int(peak_file.read_text()))
        peak_file.unlink()
        peak_file.parent.rmdir()
        self.cpu.append(usage.ru_utime + usage.ru_stime)

    @property
    def peak_bytes(self) -> int:
        return 1024 * self.peak_kib

    def note(self) -> str:
        return (
            f"peak RSS {self.peak_bytes / 2**20:.0f} MiB = {self.peak_bytes / 1e6:.0f} MB, "
            f"CPU {min(self.cpu):.2f} s"
        )


def _memory_target(peak_bytes: int) -> str:
    """The target is 300 MB = 286 MiB (VmHWM counts KiB: the MiB figure is not MB)."""
    state = "met" if peak_bytes < 300e6 else "MISSED"
    return (
        f"target 300 MB (286 MiB): ours {peak_bytes / 1e6:.0f} MB "
        f"({peak_bytes / 2**20:.0f} MiB) -> {state}"
    )


def main() -> None:
    with tempfile.TemporaryDirectory() as d:
        directory = Path(d)
        records, points = make_files(directory)
        out = directory / "out.csv"
        machine = Machine.load(MACHINE)

        predict = Benchmark(
            "csv_predict", f"mtm predict on {ROWS:,} records (read, compute, write)"
        )
        cli = Child(
            [
                *MTM,
                "predict",
                "--machine",
                MACHINE,
                str(records),
                "-o",
                str(out),
            ]
        )
        t = predict.time("ours: mtm predict (fresh process)", "ours", cli)
        t.note = cli.note()
        complete = out.read_bytes()

        def in_process():
            table = read_csv_table(records)
            q = readings_from_table(machine, table)
            xyz = np.concatenate(
                [machine.forward(q[s : s + 65536]) for s in range(0, len(q), 65536)]
            )
            columns = {c: table.text.column(c) for c in table.header}
            columns.update({c: xyz[:, k] for k, c in enumerate("xyz")})
            with atomic_write(out, "wb") as fh:
                write_columns(fh, columns, plain=table.header)

        predict.time(
            "ours: read + compute + write, in process",
            "baseline",
            in_process,
            note="not a baseline: ours without start-up",
        )

        def numpy_way():
            q = np.loadtxt(records, delimiter=",", skiprows=1)
            internal = machine.readings_from_customary(np.c_[q, np.zeros(len(q))])
            xyz = np.concatenate(
                [machine.forward(internal[s : s + 65536]) for s in range(0, len(q), 65536)]
            )
            np.savetxt(
                out,
                np.c_[q, xyz],
                fmt=["%.4f"] * 5 + ["%.6f"] * 3,
                delimiter=",",
                header="X,Y,Z,B,C,x,y,z",
                comments="",
            )

        predict.time("numpy.loadtxt + forward + numpy.savetxt", "baseline", numpy_way)

        def write_floor():
            with open(out, "wb") as fh:
                fh.write(complete)

        predict.time("write the output once", "floor", write_floor)
        predict.target("ours: mtm predict (fresh process)", 3.0, text="1 M rows < 3 s")
        predict.notes.append(_memory_target(cli.peak_bytes))
        predict.report()

        fit = Benchmark("csv_fit_sphere", f"mtm fit sphere on {ROWS:,} points (read, fit)")
        cli = Child([*MTM, "fit", "sphere", str(points), "--json"])
        t = fit.time("ours: mtm fit sphere (fresh process)", "ours", cli)
        t.note = cli.note()

        def read_only():
            table = read_csv_table(points, required=["x", "y", "z"])
            return [table.floats(c) for c in "xyz"]

        fit.time(
            "ours: strict read only, in process",
            "baseline",
            read_only,
            note="not a baseline: the reader's share",
        )
        fit.time(
            "numpy.loadtxt + fit_sphere",
            "baseline",
            lambda: fit_sphere(np.loadtxt(points, delimiter=",", skiprows=1)),
        )
        fit.time(
            "numpy.loadtxt only", "baseline", lambda: np.loadtxt(points, delimiter=",", skiprows=1)
        )
        fit.time("read the file once", "floor", points.read_bytes)
        fit.target("ours: mtm fit sphere (fresh process)", 3.0, text="1 M points < 3 s")
        fit.notes.append(_memory_target(cli.peak_bytes))
        fit.report()


if __name__ == "__main__":
    main()
