"""Benchmark: the calibration history with 10^4 stored calibrations of the 84-coefficient
model (Alami Mchichi (2018), Table 4.3) on SQLite.

Contenders, for the trend of one parameter and for the long-term covariance:
- ours: :func:`mtmetrology.history.parameter_trend` and
  :func:`mtmetrology.history.long_term_covariance` (SQLAlchemy, one query each for the
  runs and the values, then the control limits / the long-term statistic);
- baseline: the same SQL through the standard-library ``sqlite3`` driver and numpy
  (``np.cov``), no ORM, no validation;
- floor: the statistic on the values already in memory (``np.cov`` of the (K, 84) array;
  the moving range of one column).
Target: each of ours under 1 s (issue 24).
Run: ``python bench/bench_history.py``.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

import json
import sqlite3
import tempfile
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
from sqlalchemy import insert

from harness import Benchmark
from mtmetrology.history import long_term_covariance, open_history, parameter_trend, schema
from mtmetrology.kinematics.machine import Machine

RUNS = 10_000


def setup(path: Path, seed: int = 24):
    """A history of RUNS calibrations of the 84-coefficient model, bulk-inserted."""
    base = Machine.load("five-axis-wcbxfzyst")
    machine = Machine.from_spec(base.spec, model="84", source=base.name)
    names, units = machine.parameter_names, machine.parameter_units
    values = np.random.default_rng(seed).normal(size=(RUNS, len(names)))
    engine = open_history(path)
    start = datetime(2000, 1, 1, tzinfo=UTC)
    with engine.begin() as c:
        c.execute(insert(schema.Machine), [{"id": 1, "name": machine.name, "model": "84"}])
        c.execute(
            insert(schema.CalibrationRun),
            [
                {
                    "id": k + 1,
                    "machine_id": 1,
                    "kind": "parameter-set",
                    "performed_at": start + timedelta(days=k),
                    "recorded_at": start,
                    "software_version": "bench",
                    "residual_statistics": {},
                    "input_hashes": {},
                    "result": {"run": k},
                    "content_sha256": f"{k:064d}",
                    "parameter_vector": values[k].astype("<f8").tobytes(),
                }
                for k in range(RUNS)
            ],
        )
        c.execute(
            insert(schema.RunParameter),
            [
                {"run_id": k + 1, "position": j, "name": n, "unit": u, "value": float(v)}
                for k in range(RUNS)
                for j, (n, u, v) in enumerate(zip(names, units, values[k], strict=True))
            ],
        )
    return engine, machine, values


def main() -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "history.sqlite"
        engine, machine, values = setup(path)
        name = machine.name
        j = machine.parameter_names.index("E_XX1")
        bench = Benchmark("history", f"{RUNS} calibrations × {values.shape[1]} parameters, SQLite")

        def baseline_covariance():
            with sqlite3.connect(path) as c:
                rows = c.execute(
                    "SELECT parameter_vector FROM calibration_runs WHERE machine_id = 1 "
                    "ORDER BY performed_at, id"
                ).fetchall()
            matrix = np.frombuffer(b"".join(r[0] for r in rows)).reshape(len(rows), -1)
            return np.cov(matrix, rowvar=False)

        def baseline_trend():
            with sqlite3.connect(path) as c:
                column = c.execute(
                    "SELECT p.value FROM run_parameters p JOIN calibration_runs r "
                    "ON r.id = p.run_id WHERE p.name = 'E_XX1' "
                    "ORDER BY r.performed_at, r.id"
                ).fetchall()
            x = np.array(column)[:, 0]
            return x.mean(), np.abs(np.diff(x)).mean()

        bench.time("ours: trend E_XX1", "ours", lambda: parameter_trend(engine, name, "E_XX1"))
        bench.time("baseline: trend, sqlite3 + numpy", "baseline", baseline_trend)
        bench.time(
            "floor: trend statistic in memory",
            "floor",
            lambda: np.abs(np.diff(values[:, j])).mean(),
        )
        bench.time("ours: covariance", "ours", lambda: long_term_covariance(engine, name))
        bench.time("baseline: covariance, sqlite3 + numpy", "baseline", baseline_covariance)
        bench.time("floor: np.cov in memory", "floor", lambda: np.cov(values, rowvar=False))
        bench.target("ours: trend E_XX1", 1.0, text="issue 24")
        bench.target("ours: covariance", 1.0, text="issue 24")
        bench.notes.append(json.dumps({"runs": RUNS, "parameters": int(values.shape[1])}))
        bench.report()
        engine.dispose()


if __name__ == "__main__":
    main()
