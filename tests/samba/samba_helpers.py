"""Shared constants and helpers of the SAMBA tests (imported by name: conftest modules of
several folders would clash)."""

from __future__ import annotations

from pathlib import Path

from mtmetrology.samba import read_records, simulate_records
from mtmetrology.units import to_internal

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "samba"
MACHINE = "five-axis-wcbxfzyst"
NOISE = float(to_internal(0.5, "µm"))  # probing noise of one reading, mm


def simulate(tmp_path, machine, truth, balls, programme, artefact, name="records.csv", **kw):
    """Simulated records written to CSV and read back as a user's file would be."""
    path = tmp_path / name
    simulate_records(machine, truth, balls, programme, artefact, **kw).write(path)
    return read_records(path, machine, artefact)
