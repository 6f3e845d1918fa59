"""``mtm ballbar simulate|analyse|calibrate`` and ``mtm rtest simulate|calibrate`` end to
end; bad input exits 2 with one line and writes nothing."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app

runner = CliRunner()
CONDITIONS = ("--plane", "XY", "--radius", 100, "--feed", 1000, "--centre", "1000,300,300")


def mtm(*args):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def test_csv(tmp_path_factory):
    out = tmp_path_factory.mktemp("ballbar") / "xy.csv"
    res = mtm("ballbar", "simulate", "--machine", "three-axis-xfyz", *CONDITIONS,
              "--error", "E_C0Y=20", "--error", "E_XXb=2", "--error", "servo_mismatch_XY=1",
              "--noise-um", 0.3, "--seed", 1, "-o", out)  # fmt: skip
    assert res.exit_code == 0, res.output
    return out


def test_analyse_prints_g_h_f(test_csv, tmp_path):
    res = mtm("ballbar", "analyse", test_csv, *CONDITIONS, "--json", "-o", tmp_path / "a.json")
    assert res.exit_code == 0, res.output
    doc = json.loads((tmp_path / "a.json").read_text())
    assert (doc["kind"], doc["category"]) == ("iso230-4-circular", "verification")
    (test,) = doc["tests"]
    assert set(test["circular_deviation_G"]) == {"ccw", "cw"}
    assert test["circular_hysteresis_H"] > 0


def test_calibrate_identifies_the_true_errors(test_csv, tmp_path):
    out = tmp_path / "r.json"
    res = mtm("ballbar", "calibrate", test_csv, "--machine", "three-axis-xfyz", *CONDITIONS,
              "-o", out)  # fmt: skip
    assert res.exit_code == 0, res.output
    doc = json.loads(out.read_text())
    rows = {p["name"]: p for p in doc["estimates"]}
    for name, truth in (("E_C0Y", 20.0), ("E_XXb", 2.0), ("servo_mismatch_XY", 1.0)):
        assert abs(rows[name]["value"] - truth) < 4 * rows[name]["u"], name
    assert (doc["machine"], doc["category"]) == ("three-axis-xfyz", "calibration")


def test_one_radius_uncalibrated_length_exits_2_naming_the_second_test(test_csv, tmp_path):
    out = tmp_path / "r.json"
    res = mtm("ballbar", "calibrate", test_csv, "--machine", "three-axis-xfyz", *CONDITIONS,
              "--uncalibrated-length", "-o", out)  # fmt: skip
    assert res.exit_code == 2
    assert "radius 150 mm" in res.output and not out.exists()


def test_gap_in_angle_exits_2_with_one_line(test_csv, tmp_path):
    lines = test_csv.read_text().splitlines()
    cut = tmp_path / "gap.csv"
    cut.write_text("\n".join(lines[:50] + lines[60:]) + "\n")
    res = mtm("ballbar", "analyse", cut, *CONDITIONS)
    assert res.exit_code == 2
    assert "gap in angle" in res.output and len(res.output.strip().splitlines()) == 1


def test_rtest_simulate_then_calibrate(tmp_path):
    csv = tmp_path / "rt.csv"
    res = mtm("rtest", "simulate", "--machine", "five-axis-wcbxfzyst", "--index", "B=-60:60:30",
              "--index", "C=0:315:45", "--error", "E_X0C=10", "--error", "E_A0C=20",
              "-o", csv)  # fmt: skip
    assert res.exit_code == 0, res.output
    out = tmp_path / "rt.json"
    res = mtm("rtest", "calibrate", csv, "--machine", "five-axis-wcbxfzyst", "--sigma-um", 0.5,
              "-o", out)  # fmt: skip
    assert res.exit_code == 0, res.output
    doc = json.loads(out.read_text())
    rows = {p["name"]: p for p in doc["parameters"]}
    # the CSV rounds the sensor readings to 1 pm
    assert abs(rows["E_X0C"]["value"] - 10.0) < 1e-4
    assert abs(rows["E_A0C"]["value"] - 20.0) < 1e-4
    assert {d["name"] for d in doc["datum"]["dropped"]} == {"E_X0B", "E_Y0C", "E_Z0B"}


def test_rtest_bad_index_exits_2(tmp_path):
    res = mtm("rtest", "simulate", "--machine", "five-axis-wcbxfzyst", "--index", "Q=0:90:30",
              "-o", tmp_path / "x.csv")  # fmt: skip
    assert res.exit_code == 2 and "not a rotary axis" in res.output
