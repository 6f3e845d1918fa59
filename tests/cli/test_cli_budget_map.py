"""mtm budget volumetric-map: a bore on a virtual machine, and refusals."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import build_app
from mtmetrology.kinematics import Machine
from mtmetrology.multilateration.workflow import (
    Station,
    calibrate_multilateration,
    simulate_lengths,
)

M = Machine.load("three-axis-xfyz")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("vm")
    rng = np.random.default_rng(0)
    um = np.array([u == "µm" for u in M.parameter_units])
    theta = rng.normal(size=M.n_params) * np.where(um, 3e-3, 5e-6)
    stations = [
        Station("S1", (750, 50, 30), 100),
        Station("S2", (1250, 60, 40), 200),
        Station("S3", (760, 560, 20), 300),
        Station("S4", (1240, 540, 50), 400),
    ]
    tools = np.array([[0.0, 0.0, -100.0], [80.0, 0.0, -150.0], [0.0, 80.0, -150.0]])
    q = rng.uniform([800, 100, 200], [1200, 500, 400], (60, 3))
    res = calibrate_multilateration(M, simulate_lengths(M, theta, stations, q, tools, seed=1))
    (d / "map.json").write_text(json.dumps(res.to_dict()))
    other = res.to_dict() | {"machine": "another-machine"}
    (d / "other.json").write_text(json.dumps(other))
    t = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    rows = ["x,y,z,cycle"]
    for c in range(4):
        ring = np.c_[1000 + 54 * np.cos(t), 300 + 54 * np.sin(t), np.full(24, 150.0)]
        ring += rng.normal(0, 1e-3, ring.shape)
        readings = M.inverse(ring, np.zeros((24, 3)), theta)
        rows += [f"{x:.6f},{y:.6f},{z:.6f},{c}" for x, y, z in M.forward(readings)]
    (d / "points.csv").write_text("\n".join(rows) + "\n")
    return d


def _run(*args):
    return CliRunner().invoke(build_app("budget"), ["budget", "volumetric-map", *map(str, args)])


def test_bore_budget(files, tmp_path):
    out = tmp_path / "budget.json"
    html = tmp_path / "budget.html"
    r = _run(files / "points.csv", "--machine", M.name, "--params", files / "map.json",
             "--feature", "circle", "-o", out, "--report", html)  # fmt: skip
    assert r.exit_code == 0, r.output
    page = html.read_text()
    assert "U_MS" in page and "X position" in page and "points.csv" in page
    doc = json.loads(out.read_text())
    assert [row["name"] for row in doc["rows"]] == [
        "diameter", "roundness", "X position", "Y position"
    ]  # fmt: skip
    for row in doc["rows"]:
        um = row["um"]
        assert um["u_b"] == pytest.approx(abs(um["b"]))
        assert um["u"] == pytest.approx(np.sqrt(um["u_b"] ** 2 + um["u_p"] ** 2 + um["u_cal"] ** 2))
        assert 0 < um["u_cal"] < 1.0  # the LaserTRACER map is within 1 µm (seed 003)
        assert um["u_p"] > 0.1  # 1 µm probing noise over 4 cycles
    assert doc["cycles"] == 4 and doc["n_points"] == 24


def test_map_of_another_machine_refused(files, tmp_path):
    out = tmp_path / "budget.json"
    r = _run(files / "points.csv", "--machine", M.name, "--params", files / "other.json",
             "--feature", "circle", "-o", out)  # fmt: skip
    assert r.exit_code == 2
    assert "made for machine 'another-machine'" in r.output and not out.exists()


def test_too_few_points_refused(files, tmp_path):
    pts = tmp_path / "few.csv"
    pts.write_text("x,y,z\n1000,300,150\n1010,300,150\n")
    out = tmp_path / "budget.json"
    r = _run(pts, "--machine", M.name, "--params", files / "map.json", "--feature", "circle",
             "--u-p-um", "1", "-o", out)  # fmt: skip
    assert r.exit_code == 2 and "at least 3 needed" in r.output and not out.exists()
    r = _run(files / "points.csv", "--machine", M.name, "--params", files / "map.json",
             "--feature", "circle", "--probe-u", "-1", "-o", out)  # fmt: skip
    assert r.exit_code == 2 and "--probe-u" in r.output and not out.exists()
