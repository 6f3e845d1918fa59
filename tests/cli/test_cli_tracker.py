"""``mtm simulate tracker`` and ``mtm calibrate tracker`` end to end; bad input exits 2 with
one line and writes nothing (issue 21)."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

runner = CliRunner()
MACHINE = "three-axis-xfyz"
MESH = "800:1200:100,100:500:100,200:400:100"


def mtm(*args):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def measurements(tmp_path_factory):
    d = tmp_path_factory.mktemp("tracker")
    (d / "tools.yaml").write_text(
        "kind: tracker-tools\nversion: 1\n"
        "tools_mm: [[0, 0, -100], [100, 0, -100], [0, 100, -100]]\n"
    )
    out = d / "meas.csv"
    res = mtm("simulate", "tracker", "--machine", MACHINE, "--mesh", MESH, "--tools",
              d / "tools.yaml", "--seed", 4, "-o", out)  # fmt: skip
    assert res.exit_code == 0, res.output
    return out


def test_simulate_then_calibrate_writes_a_parameter_set_predict_reads(measurements, tmp_path):
    res = mtm("calibrate", "tracker", measurements, "--machine", MACHINE, "--json",
              "-o", tmp_path / "r.json")  # fmt: skip
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["kind"] == "tracker-calibration"
    assert doc["datum"]["rank"] == 53 and doc["datum"]["n_unknowns"] == 57
    assert len(doc["residuals_um"]) == 225
    pset = ParameterSet.load(tmp_path / "r.json", Machine.load(MACHINE))
    # the 47 of the datum and E_CZ0, the tool's yaw the three lateral tools expose
    assert pset.covariance.shape == (48, 48) and pset.names[-1] == "E_CZ0"


def _refused(res, tmp_path, first_words):
    assert res.exit_code == 2
    lines = res.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(first_words)
    assert not any(p.suffix in (".csv", ".json") for p in tmp_path.iterdir())


def test_pose_inside_workspace_refused(tmp_path):
    pose = tmp_path / "pose.yaml"
    pose.write_text("kind: tracker-pose\nversion: 1\nD_mm: 1000\nL_mm: 300\nH_mm: 300\n"
                    "alpha_deg: 0\nbeta_deg: 0\ndelta_deg: 0\n")  # fmt: skip
    res = mtm("simulate", "tracker", "--machine", MACHINE, "--mesh", MESH, "--pose", pose,
              "-o", tmp_path / "m.csv")  # fmt: skip
    _refused(res, tmp_path, "error: pose: the tracker at D, L, H = 1000, 300, 300 mm lies inside")


def test_mesh_outside_travel_refused(tmp_path):
    res = mtm("simulate", "tracker", "--machine", MACHINE, "--mesh",
              "800:1200:100,100:600:100,200:400:100", "-o", tmp_path / "m.csv")  # fmt: skip
    _refused(res, tmp_path, "error: --mesh: Y = 600 mm lies outside the travel")


def test_nan_pose_field_refused(tmp_path):
    pose = tmp_path / "pose.yaml"
    pose.write_text("kind: tracker-pose\nversion: 1\nD_mm: .nan\nL_mm: 300\nH_mm: 300\n"
                    "alpha_deg: 0\nbeta_deg: 0\ndelta_deg: 0\n")  # fmt: skip
    res = mtm("simulate", "tracker", "--machine", MACHINE, "--mesh", MESH, "--pose", pose,
              "-o", tmp_path / "m.csv")  # fmt: skip
    assert res.exit_code == 2
    assert "D_mm" in res.output.strip().splitlines()[0]
    assert not (tmp_path / "m.csv").exists()


def test_reading_beyond_tracker_limits_and_nan_reading_refused(measurements, tmp_path):
    lines = measurements.read_text().splitlines()
    cells = lines[5].split(",")
    cells[9] = "-60"  # elevation of data row 5
    steep = tmp_path / "steep.csv"
    steep.write_text("\n".join([*lines[:5], ",".join(cells), *lines[6:]]) + "\n")
    res = mtm("calibrate", "tracker", steep, "--machine", MACHINE, "-o", tmp_path / "r.json")
    assert res.exit_code == 2
    assert (
        res.output.strip() == "error: measurement 5: elevation -60.00° beyond ±45° of the tracker"
    )
    assert not (tmp_path / "r.json").exists()
    cells[9] = "nan"
    nan = tmp_path / "nan.csv"
    nan.write_text("\n".join([*lines[:5], ",".join(cells), *lines[6:]]) + "\n")
    res = mtm("calibrate", "tracker", nan, "--machine", MACHINE, "-o", tmp_path / "r.json")
    assert res.exit_code == 2
    assert "elevation" in res.output and len(res.output.strip().splitlines()) == 1
    assert not (tmp_path / "r.json").exists()


def test_verify_tracker_json_and_report(tmp_path):
    res = mtm("verify", "tracker", "--machine", MACHINE, "--trials", 50, "--seed", 1, "--json",
              "--report", tmp_path / "v.html")  # fmt: skip
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["kind"] == "tracker-verification"
    assert len(doc["mean_final_um"]) == 50 and doc["coverage"]["trials"] == 50
    s = doc["statistics"]
    assert s["mean_plus_2sigma_um"] == pytest.approx(s["mean_final_um"] + 2 * s["sigma_final_um"])
    assert (tmp_path / "v.html").stat().st_size > 1000


def test_verify_tracker_bad_trials_writes_nothing(tmp_path):
    res = mtm("verify", "tracker", "--machine", MACHINE, "--trials", 2, "-o", tmp_path / "v.json")
    _refused(res, tmp_path, "error: --trials must be an integer >= 10, got 2")


def test_design_tracker_placement_json(tmp_path):
    res = mtm("design", "tracker-placement", "--machine", MACHINE, "--trials", 2000,
              "--seed", 2, "--json", "--report", tmp_path / "p.html")  # fmt: skip
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["kind"] == "tracker-placement" and doc["criterion"] == "max"
    assert doc["best_value_um"] == pytest.approx(min(doc["criterion_um"]))
    assert len(doc["criterion_um"]) + doc["refused"] == 2000


def test_design_tracker_placement_bad_region_writes_nothing(tmp_path):
    res = mtm("design", "tracker-placement", "--machine", MACHINE, "--region", "a:b,1:2",
              "-o", tmp_path / "p.json")  # fmt: skip
    _refused(res, tmp_path, "error: --region needs D0:D1,L0:L1,H0:H1 in mm")


def test_conditions_file_is_read_and_a_bad_key_named(tmp_path):
    cond = tmp_path / "cond.yaml"
    cond.write_text("kind: tracker-conditions\nversion: 1\n"
                    "sensor_temperatures_C: [[25, 25], [25, 25], [25, 25]]\nu_sensor_K: 0.0\n"
                    "u_cte_per_K: [0, 0, 0]\n")  # fmt: skip
    out = tmp_path / "m.csv"
    res = mtm("simulate", "tracker", "--machine", MACHINE, "--mesh", MESH, "--conditions", cond,
              "--seed", 1, "-o", out)  # fmt: skip
    assert res.exit_code == 0, res.output
    temps = [line.split(",")[-3:] for line in out.read_text().splitlines()[1:]]
    assert {float(v) for row in temps for v in row} == {25.0}
    bad = tmp_path / "bad.yaml"
    bad.write_text("kind: tracker-conditions\nversion: 1\ncte: [1, 2, 3]\n")
    res = mtm("simulate", "tracker", "--machine", MACHINE, "--mesh", MESH, "--conditions", bad,
              "-o", tmp_path / "n.csv")  # fmt: skip
    assert res.exit_code == 2
    assert res.output.strip().startswith(f"error: {bad}: cte: unknown key")
    assert not (tmp_path / "n.csv").exists()
