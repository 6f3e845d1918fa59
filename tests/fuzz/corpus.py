"""Valid input files for every command of ``mtm``, and how a run is classified.

The fuzz tests start from these files, break one thing, run the command in-process
(typer's CliRunner) and sort the outcome into the classes of issue 9:

- ``clear``: exit 2 (3 for the environment), one ``error:`` line naming the file,
  no traceback, nothing written (no output file, no temporary, nothing on stdout);
- ``unclear``: a traceback, an internal error, several lines, or a message that names
  neither the file nor the option;
- ``silent``: exit 0 with a result computed from the bad input;
- ``slow``: a run longer than :data:`SLOW_SECONDS` (a hang or an unbounded climb).
"""

from __future__ import annotations

import json
import os
import time
import zlib
from collections import Counter
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, settings
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.samba import SambaSetup, probing_sequence

SLOW_SECONDS = 20.0
#: ``MTM_FUZZ=all`` (``make fuzz``) runs the whole corpus; CI runs a sample.
FULL = os.environ.get("MTM_FUZZ", "") == "all"
#: Classes of every run of this session (printed by the conftest at the end).
CENSUS: Counter = Counter()

# CI draws the same examples every run (a red CI names a change, not a draw); `make fuzz`
# draws fresh ones to explore.
settings.register_profile(
    "fuzz-ci",
    max_examples=4,
    deadline=None,
    derandomize=True,
    suppress_health_check=list(HealthCheck),
)
settings.register_profile(
    "fuzz-all", max_examples=150, deadline=None, suppress_health_check=list(HealthCheck)
)


def sampled(case_id: str, every: int = 6) -> bool:
    """Whether a case runs in the CI sample (a fixed, spread subset of the catalogue)."""
    return FULL or zlib.crc32(case_id.encode()) % every == 0


def fuzz_settings():
    """The hypothesis settings of the current mode."""
    return settings.get_profile("fuzz-all" if FULL else "fuzz-ci")


MACHINE = (
    resources.files("mtmetrology.kinematics")
    .joinpath("presets/five-axis-wcbxfzyst.yaml")
    .read_text(encoding="utf-8")
)
ARTEFACT = """kind: samba-artefact
version: 1
balls:
  - {id: "1", diameter_mm: 12.7}
  - {id: "2", diameter_mm: 12.7}
  - {id: SB1, diameter_mm: 12.7}
  - {id: SB2, diameter_mm: 12.7}
scale_bar: {ends: [SB1, SB2], length_mm: 305.2105, u_mm: 0.0012}
"""
MODEL = """kind: measurement-model
version: 1
name: sum and difference
inputs:
  - {name: a, value: 10.0, u: 0.3, unit: µm}
  - {name: b, value: 5.0, u: 0.4, unit: µm}
outputs:
  - {name: s, expression: "a + b", unit: µm}
  - {name: d, expression: "a - b", unit: µm}
"""


def _params() -> str:
    zero = ParameterSet.zeros(Machine.load("five-axis-wcbxfzyst"))
    values = np.linspace(-5.0, 5.0, len(zero.names)) * zero.scales()  # ±5 µm, µrad, µm/m
    doc = ParameterSet(
        zero.names, values, zero.units, machine=zero.machine, model=zero.model
    ).to_document()
    return json.dumps(doc, indent=2)


def _records() -> str:
    rng = np.random.default_rng(9)
    n = 20
    cols = {
        "X": rng.uniform(-200, 200, n),
        "Y": rng.uniform(-150, 150, n),
        "Z": rng.uniform(-100, 200, n),
        "B": rng.uniform(-90, 90, n),
        "C": rng.uniform(0, 360, n),
    }
    lines = ["X,Y,Z,B,C"] + [",".join(f"{cols[c][i]:.4f}" for c in cols) for i in range(n)]
    return "\n".join(lines) + "\n"


def _points() -> str:
    rng = np.random.default_rng(4)
    u = rng.normal(size=(40, 3))
    p = 12.5 * u / np.linalg.norm(u, axis=1, keepdims=True) + (1.0, -2.0, 3.0)
    return "x,y,z\n" + "\n".join(",".join(f"{v:.6f}" for v in row) for row in p) + "\n"


def _poses() -> str:
    m = Machine.load("five-axis-wcbxfzyst")
    setup = SambaSetup(
        balls={"1": (-80, -40, 100), "2": (80, 120, 150)},
        scale_bar={"SB1": (-152.60525, 0, 30), "SB2": (152.60525, 0, 30)},
    )
    pairs = [(b, c) for b in (-60, -30, 0, 30, 60) for c in range(0, 360, 60)]
    ids, q = probing_sequence(m, setup, pairs)
    c = m.readings_to_customary(q)
    rows = [f"{i}," + ",".join(f"{v:.6f}" for v in row) for i, row in zip(ids, c, strict=True)]
    return "\n".join(["ball,X,Y,Z,B,C,S", *rows]) + "\n"


def valid_files() -> dict[str, str]:
    """Name -> text of one valid file of every kind the commands read."""
    return {
        "machine": MACHINE,
        "params": _params(),
        "records": _records(),
        "points": _points(),
        "poses": _poses(),
        "artefact": ARTEFACT,
        "model": MODEL,
    }


FILE_NAMES = {
    "machine": "machine.yaml",
    "params": "params.json",
    "records": "records.csv",
    "points": "points.csv",
    "poses": "poses.csv",
    "artefact": "artefact.yaml",
    "model": "model.yaml",
}


@dataclass
class Outcome:
    """What one run did, and its class."""

    label: str
    exit_code: int
    stderr: str
    stdout: str
    seconds: float
    written: list[str] = field(default_factory=list)

    @property
    def error_lines(self) -> list[str]:
        return [line for line in self.stderr.splitlines() if line.strip()]


def materialise(directory: Path, files: dict[str, str | bytes]) -> dict[str, str]:
    """Write the files; return placeholder -> path (plus ``out`` and ``dir``)."""
    paths = {}
    for key, content in files.items():
        p = directory / FILE_NAMES[key]
        if isinstance(content, bytes):
            p.write_bytes(content)
        else:
            p.write_text(content, encoding="utf-8", newline="")
        paths[key] = str(p)
    paths["out"] = str(directory / "out.csv")
    paths["dir"] = str(directory)
    return paths


def run(args: list[str], directory: Path, names: str | None) -> Outcome:
    """Run ``mtm args`` in-process and classify the result (see the module notes)."""
    before = set(os.listdir(directory))
    start = time.perf_counter()
    result = CliRunner().invoke(app, args, catch_exceptions=True)
    seconds = time.perf_counter() - start
    written = sorted(set(os.listdir(directory)) - before)
    stderr, stdout = result.stderr, result.stdout
    code = result.exit_code
    lines = [line for line in stderr.splitlines() if line.strip()]
    if seconds > SLOW_SECONDS:
        label = "slow"
    elif code == 0:
        label = "silent"
    elif (
        code in (2, 3)
        and len(lines) == 1
        and lines[0].startswith("error: ")
        and "Traceback" not in stderr
        and not written
        and not stdout.strip()
        and (names is None or names in lines[0])
    ):
        label = "clear"
    else:
        label = "unclear"
    return Outcome(label, code, stderr, stdout, seconds, written)
