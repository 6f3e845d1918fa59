"""mtm multilateration simulate / mtm multilateration calibrate: round trip and refusals."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import build_app
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

STATIONS = """kind: multilateration-stations
version: 1
stations:
  - {name: S1, position_mm: [750, 50, 30], dead_path_mm: 100}
  - {name: S2, position_mm: [1250, 60, 40], dead_path_mm: 200}
  - {name: S3, position_mm: [760, 560, 20], dead_path_mm: 300}
  - {name: S4, position_mm: [1240, 540, 50], dead_path_mm: 400}
"""
TRUTH = {
    "kind": "parameter-set",
    "version": 1,
    "machine": "three-axis-xfyz",
    "model": "21-legendre",
    "parameters": [
        {"name": "E_XX1", "value": 8.0, "unit": "µm"},
        {"name": "E_YY2", "value": -4.0, "unit": "µm"},
        {"name": "E_C0Y", "value": 15.0, "unit": "µrad"},
        {"name": "E_CY1", "value": 5.0, "unit": "µrad"},
    ],
}


def _run(group, *args):
    return CliRunner().invoke(build_app(group), [group, *map(str, args)])


@pytest.fixture(scope="module")
def lengths(tmp_path_factory):
    d = tmp_path_factory.mktemp("ml")
    (d / "stations.yaml").write_text(STATIONS)
    (d / "truth.json").write_text(json.dumps(TRUTH))
    out = d / "lengths.csv"
    r = _run(
        "multilateration", "simulate", "--machine", "three-axis-xfyz", "--truth",
        d / "truth.json", "--stations", d / "stations.yaml", "--grid", "4,4,4",
        "--seed", 1, "-o", out,
    )  # fmt: skip
    assert r.exit_code == 0, r.output
    return out


def test_calibrate_recovers_the_truth_within_its_uncertainty(lengths, tmp_path):
    out = tmp_path / "map.json"
    r = _run("multilateration", "calibrate", lengths, "--machine", "three-axis-xfyz", "-o", out)
    assert r.exit_code == 0, r.output
    m = Machine.load("three-axis-xfyz")
    pset = ParameterSet.load(out, m)
    # the model's 51 and the tool constants the three reflectors expose (zero here)
    assert pset.names == (*m.parameter_names, "E_AZ0", "E_BZ0", "E_CZ0")
    truth = np.zeros(len(pset.names))
    for e in TRUTH["parameters"]:
        truth[pset.names.index(e["name"])] = e["value"] * (1e-3 if e["unit"] == "µm" else 1e-6)
    z = (pset.values - truth) / pset.standard_uncertainty
    assert np.abs(z).max() < 5.0  # 54 normal deviates: |z| < 5 fails with p < 3e-5
    doc = json.loads(out.read_text())
    assert doc["provenance"]["method"] == "sequential multilateration"
    assert [s["name"] for s in doc["provenance"]["stations"]] == ["S1", "S2", "S3", "S4"]


def test_station_seeing_too_few_points_is_refused(lengths, tmp_path):
    rows = lengths.read_text().splitlines()
    kept = (
        [rows[0]]
        + [r for r in rows[1:] if not r.startswith("S4")]
        + [r for r in rows[1:] if r.startswith("S4")][:3]
    )
    bad = tmp_path / "few.csv"
    bad.write_text("\n".join(kept) + "\n")
    out = tmp_path / "map.json"
    r = _run("multilateration", "calibrate", bad, "--machine", "three-axis-xfyz", "-o", out)
    assert r.exit_code == 2
    assert "station S4 sees 3 points" in r.output
    assert not out.exists()


def test_one_tool_names_the_unobservable_yaws(tmp_path):
    (tmp_path / "stations.yaml").write_text(STATIONS)
    one = tmp_path / "one.csv"
    r = _run(
        "multilateration", "simulate", "--machine", "three-axis-xfyz", "--stations",
        tmp_path / "stations.yaml", "--grid", "4,4,4", "--tool", "0,0,-100", "-o", one,
    )  # fmt: skip
    assert r.exit_code == 0, r.output
    out = tmp_path / "map.json"
    r = _run("multilateration", "calibrate", one, "--machine", "three-axis-xfyz", "-o", out)
    assert r.exit_code == 2
    assert "E_CZ1 (not observable)" in r.output and "E_CY1 (not observable)" in r.output
    assert not out.exists()


def test_negative_noise_refused(lengths, tmp_path):
    out = tmp_path / "map.json"
    r = _run(
        "multilateration", "calibrate", lengths, "--machine", "three-axis-xfyz",
        "--noise", "-0.2um+0.3um/m", "-o", out,
    )  # fmt: skip
    assert r.exit_code == 2 and "--noise" in r.output and not out.exists()
