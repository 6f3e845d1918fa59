"""SIGINT and SIGKILL at random moments of ``mtm predict -o`` on a large file.

Whatever the moment (start-up, reading, computing, writing, renaming), the target is the
old file, absent, or complete, never anything else; SIGINT ends with the one line
``interrupted; nothing written`` and exit code 130 (or 0 if the run had finished), and
leaves no temporary file.  The only exception is a SIGINT in the interpreter's own first
milliseconds, before any code of the project runs (see :func:`_before_any_project_code`).
CI runs 2 of each signal; ``MTM_FUZZ=all`` runs 20 of each.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from tests.fuzz.corpus import FULL

from mtmetrology.io import sweep_temporaries

SRC = str(Path(__file__).resolve().parents[2] / "src")
#: ``mtm`` as its console script runs it.
MTM = [sys.executable, "-c", "from mtmetrology.__main__ import main; main()"]
ROWS = 200_000 if FULL else 50_000
TRIALS = 20 if FULL else 2
OLD = b"an old result\n"


def _command(records: Path, target: Path) -> list[str]:
    return [
        *MTM,
        "predict",
        "--machine",
        "five-axis-wcbxfzyst",
        str(records),
        "-o",
        str(target),
    ]


def _env() -> dict[str, str]:
    return {**os.environ, "PYTHONPATH": SRC + os.pathsep + os.environ.get("PYTHONPATH", "")}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """A large records file, its complete output, and the duration of one full run."""
    d = tmp_path_factory.mktemp("kill")
    rng = np.random.default_rng(11)
    q = np.column_stack(
        [
            rng.uniform(-200, 200, ROWS),
            rng.uniform(-150, 150, ROWS),
            rng.uniform(-100, 200, ROWS),
            rng.uniform(-90, 90, ROWS),
            rng.uniform(0, 360, ROWS),
        ]
    )
    records = d / "records.csv"
    np.savetxt(records, q, fmt="%.4f", delimiter=",", header="X,Y,Z,B,C", comments="")
    target = d / "complete.csv"
    start = time.perf_counter()
    subprocess.run(_command(records, target), env=_env(), check=True, capture_output=True)
    return records, target.read_bytes(), time.perf_counter() - start


def _before_any_project_code(returncode: int, stderr: bytes) -> bool:
    """A SIGINT in the first milliseconds stops Python itself: before its SIGINT handler is
    installed (killed by the signal), while ``site`` imports, or while the entry point
    ``from mtmetrology.__main__ import main`` is being imported (two files of a few lines
    that import nothing else), before the ``try`` of :func:`mtmetrology.__main__.main`
    can catch it."""
    text = stderr.decode()
    if returncode == -signal.SIGINT and not text:
        return True
    frames = re.findall(r'File "([^"]+)"', text)
    entry = ("<string>", "mtmetrology/__init__.py", "mtmetrology/__main__.py")
    return text.rstrip().endswith("KeyboardInterrupt") and all(
        f.startswith("<frozen ") or f.endswith(entry) or _stdlib(f) for f in frames
    )


def _stdlib(frame_file: str) -> bool:
    return "/lib/python3" in frame_file and "site-packages" not in frame_file


def _temporaries(directory: Path) -> list[str]:
    return [p.name for p in directory.iterdir() if p.name.endswith(".tmp")]


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGKILL], ids=["SIGINT", "SIGKILL"])
def test_a_killed_write_leaves_the_old_target_no_target_or_the_complete_one(
    reference, tmp_path, sig
):
    records, complete, duration = reference
    rng = np.random.default_rng(20261124 + int(sig))
    outcomes = []
    for trial in range(TRIALS):
        directory = tmp_path / f"trial{trial}"
        directory.mkdir()
        target = directory / "out.csv"
        had_old = trial % 2 == 0
        if had_old:
            target.write_bytes(OLD)
        process = subprocess.Popen(
            _command(records, target), env=_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE
        )
        time.sleep(rng.uniform(0.0, 1.1 * duration))
        process.send_signal(sig)
        _, stderr = process.communicate(timeout=120)
        content = target.read_bytes() if target.exists() else None
        assert content in ((OLD if had_old else None), complete), (trial, content and len(content))
        outcomes.append((process.returncode, content == complete))
        if sig == signal.SIGINT:
            lines = stderr.decode().strip().splitlines()
            if process.returncode == 130:
                assert lines == ["interrupted; nothing written"], stderr
                assert content != complete
            elif process.returncode != 0:  # the interpreter's own start-up was interrupted
                assert _before_any_project_code(process.returncode, stderr), stderr
                assert content == (OLD if had_old else None)
            assert _temporaries(directory) == []
        else:
            sweep_temporaries(target)  # a stale named temporary is the project's to remove
            assert _temporaries(directory) == []
    assert len(outcomes) == TRIALS
