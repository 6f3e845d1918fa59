"""Files of a multilateration: STATIONS.yaml and LENGTHS.csv.

STATIONS.yaml (a simulation's true stations)::

    kind: multilateration-stations
    version: 1
    stations:
      - {name: S1, position_mm: [750, 50, 30], dead_path_mm: 100}

LENGTHS.csv, one interferometer length per row (mm; one column per axis of the machine,
rotary axes in degrees)::

    station,X,Y,Z,tool_x,tool_y,tool_z,length
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from mtmetrology.io import InputFileError, read_csv_table
from mtmetrology.io.documents import load_document
from mtmetrology.io.tables import write_csv_table
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.readings_table import readings_from_table
from mtmetrology.multilateration.workflow import LengthRecord, Station

__all__ = ["STATIONS_KIND", "read_lengths", "read_stations", "write_lengths"]

STATIONS_KIND = "multilateration-stations"
_TOOL = ("tool_x", "tool_y", "tool_z")


_STATION_KEYS = ("name", "position_mm", "dead_path_mm")


def read_stations(path: str | Path) -> list[Station]:
    """Stations of a STATIONS.yaml (strict: kind, version, names unique, numbers finite)."""
    doc = load_document(path, "stations file")
    if not isinstance(doc, dict) or doc.get("kind") != STATIONS_KIND:
        raise InputFileError(f"{path}: kind must be {STATIONS_KIND!r}")
    if doc.get("version") != 1:
        raise InputFileError(f"{path}: version must be 1")
    entries = doc.get("stations")
    if not isinstance(entries, list) or not entries:
        raise InputFileError(f"{path}: stations: a non-empty list is needed")
    out = []
    unknown = sorted(set(doc) - {"kind", "version", "stations"})
    if unknown:
        raise InputFileError(f"{path}: {unknown[0]}: unknown key (kind, version, stations)")
    for k, e in enumerate(entries):
        where = f"{path}: stations[{k}]"
        if not isinstance(e, dict) or not {"name", "position_mm"} <= set(e):
            raise InputFileError(f"{where}: needs name and position_mm")
        unknown = sorted(set(e) - set(_STATION_KEYS))
        if unknown:
            raise InputFileError(
                f"{where}: {unknown[0]}: unknown key (a station has {', '.join(_STATION_KEYS)})"
            )
        pos = e["position_mm"]
        if (
            not isinstance(pos, list)
            or len(pos) != 3
            or not all(isinstance(v, int | float) and math.isfinite(v) for v in pos)
        ):
            raise InputFileError(f"{where}: position_mm must be three numbers")
        dead = e.get("dead_path_mm", 0.0)
        if isinstance(dead, bool) or not isinstance(dead, int | float) or not math.isfinite(dead):
            raise InputFileError(f"{where}: dead_path_mm must be a number")
        if dead < 0:
            raise InputFileError(
                f"{where}: dead_path_mm must be >= 0 (the interferometer's path before the "
                f"reflector), got {dead:g}"
            )
        out.append(Station(str(e["name"]), tuple(float(v) for v in pos), float(dead)))
    names = [s.name for s in out]
    if len(set(names)) != len(names):
        raise InputFileError(f"{path}: a station name is used twice")
    return out


def read_lengths(path: str | Path, machine: Machine) -> LengthRecord:
    """LENGTHS.csv of ``machine`` (module notes): readings in internal units; a reading
    outside the travel, a NaN or a missing column is refused naming the file and line."""
    table = read_csv_table(path, required=["station", *machine.axis_names, *_TOOL, "length"])
    q = readings_from_table(machine, table)  # a reading outside the travel is refused
    tools = np.column_stack([table.floats(c) for c in _TOOL])
    lengths = table.floats("length")
    return LengthRecord(q, tools, tuple(table.strings("station")), lengths)


def write_lengths(path: str | Path, machine: Machine, record: LengthRecord) -> None:
    """Write a LengthRecord as LENGTHS.csv (µm-resolved: 7 decimals of mm, 0.1 nm)."""
    q = machine.readings_to_customary(record.readings)
    rows = [
        [s, *(f"{v:.7f}" for v in qi), *(f"{v:.7f}" for v in t), f"{ell:.7f}"]
        for s, qi, t, ell in zip(record.stations, q, record.tools, record.lengths, strict=True)
    ]
    write_csv_table(path, ["station", *machine.axis_names, *_TOOL, "length"], rows)
