"""``mtm predict --u``: the compensated coordinates' uncertainty from the parameter
covariance (issue 19: what compensates with an estimate carries its uncertainty)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app

runner = CliRunner()
MACHINE = "five-axis-wcbxfzyst"


def _files(tmp_path, u_um_per_m):
    (tmp_path / "r.csv").write_text("X,Y,Z,B,C\n100,0,100,0,0\n-50,20,80,0,0\n", "utf-8")
    entry = {"name": "E_XX1", "value": -50.0, "unit": "µm/m"}
    if u_um_per_m is not None:
        entry["u"] = u_um_per_m
    doc = {"kind": "parameter-set", "version": 1, "machine": MACHINE, "parameters": [entry]}
    (tmp_path / "p.json").write_text(json.dumps(doc), "utf-8")
    return [str(tmp_path / "r.csv"), "--machine", MACHINE, "--params", str(tmp_path / "p.json")]


def test_u_of_a_calibrated_scale_error_is_x_times_its_u(tmp_path):
    """Only E_XX1 = −50 µm/m with u = 10 µm/m: x = X(1 + δ̂) and u(x) = |X|·10 µm/m, i.e.
    1.0 µm at X = 100 mm and 0.5 µm at X = −50 mm; y, z do not depend on it."""
    result = runner.invoke(app, ["predict", *_files(tmp_path, 10.0), "--u"])
    assert result.exit_code == 0, result.output
    lines = result.stdout.splitlines()
    assert lines[0] == "X,Y,Z,B,C,x,y,z,u_x_um,u_y_um,u_z_um"
    rows = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    np.testing.assert_allclose(rows[:, 5], rows[:, 0] * (1 - 50e-6), rtol=0, atol=1e-6)
    np.testing.assert_allclose(rows[:, 8], [1.0, 0.5], rtol=0, atol=1e-6)
    np.testing.assert_allclose(rows[:, 9:], 0.0, atol=1e-6)


def test_u_without_a_covariance_is_refused_and_nothing_written(tmp_path):
    out = tmp_path / "out.csv"
    result = runner.invoke(app, ["predict", *_files(tmp_path, None), "--u", "-o", str(out)])
    assert result.exit_code == 2
    (line,) = result.stderr.strip().splitlines()
    assert line.startswith("error: ") and "--u" in line and "covariance" in line
    assert not out.exists()


@pytest.mark.parametrize("u", [None, 10.0])
def test_without_u_the_output_has_no_u_columns(tmp_path, u):
    result = runner.invoke(app, ["predict", *_files(tmp_path, u)])
    assert result.exit_code == 0, result.output
    assert result.stdout.splitlines()[0] == "X,Y,Z,B,C,x,y,z"
