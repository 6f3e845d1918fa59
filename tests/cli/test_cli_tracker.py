"""``mtm tracker simulate`` and ``mtm tracker calibrate`` end to end; bad input exits 2 with
one line and writes nothing (issue 21)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.lengths import pair_lengths
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
    res = mtm("tracker", "simulate", "--machine", MACHINE, "--mesh", MESH, "--tools",
              d / "tools.yaml", "--seed", 4, "-o", out)  # fmt: skip
    assert res.exit_code == 0, res.output
    return out


def test_simulate_then_calibrate_writes_a_parameter_set_predict_reads(measurements, tmp_path):
    res = mtm("tracker", "calibrate", measurements, "--machine", MACHINE, "--json",
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
    res = mtm("tracker", "simulate", "--machine", MACHINE, "--mesh", MESH, "--pose", pose,
              "-o", tmp_path / "m.csv")  # fmt: skip
    _refused(res, tmp_path, "error: pose: the tracker at D, L, H = 1000, 300, 300 mm lies inside")


def test_mesh_outside_travel_refused(tmp_path):
    res = mtm("tracker", "simulate", "--machine", MACHINE, "--mesh",
              "800:1200:100,100:600:100,200:400:100", "-o", tmp_path / "m.csv")  # fmt: skip
    _refused(res, tmp_path, "error: --mesh: Y = 600 mm lies outside the travel")


def test_nan_pose_field_refused(tmp_path):
    pose = tmp_path / "pose.yaml"
    pose.write_text("kind: tracker-pose\nversion: 1\nD_mm: .nan\nL_mm: 300\nH_mm: 300\n"
                    "alpha_deg: 0\nbeta_deg: 0\ndelta_deg: 0\n")  # fmt: skip
    res = mtm("tracker", "simulate", "--machine", MACHINE, "--mesh", MESH, "--pose", pose,
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
    res = mtm("tracker", "calibrate", steep, "--machine", MACHINE, "-o", tmp_path / "r.json")
    assert res.exit_code == 2
    assert (
        res.output.strip()
        == f"error: {steep}, line 6: elevation -60.00° beyond ±45° of the tracker"
    )
    assert not (tmp_path / "r.json").exists()
    cells[9] = "nan"
    nan = tmp_path / "nan.csv"
    nan.write_text("\n".join([*lines[:5], ",".join(cells), *lines[6:]]) + "\n")
    res = mtm("tracker", "calibrate", nan, "--machine", MACHINE, "-o", tmp_path / "r.json")
    assert res.exit_code == 2
    assert "elevation" in res.output and len(res.output.strip().splitlines()) == 1
    assert not (tmp_path / "r.json").exists()


def test_verify_tracker_json_and_report(tmp_path):
    res = mtm("tracker", "verify", "--machine", MACHINE, "--trials", 50, "--seed", 1, "--json",
              "--report", tmp_path / "v.html")  # fmt: skip
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["kind"] == "tracker-verification"
    assert len(doc["mean_final_um"]) == 50 and doc["coverage"]["trials"] == 50
    s = doc["statistics"]
    assert s["mean_plus_2sigma_um"] == pytest.approx(s["mean_final_um"] + 2 * s["sigma_final_um"])
    assert (tmp_path / "v.html").stat().st_size > 1000


def test_verify_tracker_bad_trials_writes_nothing(tmp_path):
    res = mtm("tracker", "verify", "--machine", MACHINE, "--trials", 2, "-o", tmp_path / "v.json")
    _refused(res, tmp_path, "error: --trials must be an integer >= 10, got 2")


def test_design_tracker_placement_json(tmp_path):
    res = mtm("tracker", "plan", "--machine", MACHINE, "--trials", 2000,
              "--seed", 2, "--json", "--report", tmp_path / "p.html")  # fmt: skip
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["kind"] == "tracker-placement" and doc["criterion"] == "max"
    assert doc["best_value_um"] == pytest.approx(min(doc["criterion_um"]))
    assert len(doc["criterion_um"]) + doc["refused"] == 2000


def test_design_tracker_placement_bad_region_writes_nothing(tmp_path):
    res = mtm("tracker", "plan", "--machine", MACHINE, "--region", "a:b,1:2",
              "-o", tmp_path / "p.json")  # fmt: skip
    _refused(res, tmp_path, "error: --region needs D0:D1,L0:L1,H0:H1 in mm")


def test_conditions_file_is_read_and_a_bad_key_named(tmp_path):
    cond = tmp_path / "cond.yaml"
    cond.write_text("kind: tracker-conditions\nversion: 1\n"
                    "sensor_temperatures_C: [[25, 25], [25, 25], [25, 25]]\nu_sensor_K: 0.0\n"
                    "u_cte_per_K: [0, 0, 0]\n")  # fmt: skip
    out = tmp_path / "m.csv"
    res = mtm("tracker", "simulate", "--machine", MACHINE, "--mesh", MESH, "--conditions", cond,
              "--seed", 1, "-o", out)  # fmt: skip
    assert res.exit_code == 0, res.output
    temps = [line.split(",")[-3:] for line in out.read_text().splitlines()[1:]]
    assert {float(v) for row in temps for v in row} == {25.0}
    bad = tmp_path / "bad.yaml"
    bad.write_text("kind: tracker-conditions\nversion: 1\ncte: [1, 2, 3]\n")
    res = mtm("tracker", "simulate", "--machine", MACHINE, "--mesh", MESH, "--conditions", bad,
              "-o", tmp_path / "n.csv")  # fmt: skip
    assert res.exit_code == 2
    assert res.output.strip().startswith(f"error: {bad}: cte: unknown key")
    assert not (tmp_path / "n.csv").exists()


def test_noise_options_set_the_weights_and_bad_values_are_refused(measurements, tmp_path):
    """Issue 30: --range-noise A,B (µm, µm/m), --angle-urad, --angle-spread, --smr reach the
    noise model the calibration weights with; the source's values otherwise."""
    res = mtm("tracker", "calibrate", measurements, "--machine", MACHINE, "--json",
              "--range-noise", "1.5,0.4", "--angle-urad", 5, "--angle-spread", 0,
              "--smr", 2)  # fmt: skip
    assert res.exit_code == 0, res.output
    noise = json.loads(res.stdout)["calibration_provenance"]["noise"]
    assert noise["u_range_constant_um"] == pytest.approx(1.5)
    assert noise["u_range_per_length_um_per_m"] == pytest.approx(0.4)
    assert noise["u_angle_urad"] == pytest.approx(5.0)
    assert noise["u_angle_spread_urad"] == 0.0
    assert noise["u_smr_um"] == pytest.approx(2.0)
    default = mtm("tracker", "calibrate", measurements, "--machine", MACHINE, "--json")
    noise = json.loads(default.stdout)["calibration_provenance"]["noise"]
    assert (noise["u_range_constant_um"], noise["u_angle_spread_urad"]) == (4.0, 3.0)
    for option, value, words in (("--range-noise", "1.5", "must be"),
                                 ("--range-noise", "1,-2", "must be"),
                                 ("--angle-spread", "nan", ": expected a finite number"),
                                 ("--smr", "-1", "must be")):  # fmt: skip
        out = tmp_path / "r.json"
        res = mtm("tracker", "calibrate", measurements, "--machine", MACHINE, option, value,
                  "-o", out)  # fmt: skip
        _refused(res, tmp_path, f"error: {option}{'' if words[0] == ':' else ' '}{words}")


def test_tool_ids_give_the_offsets_of_a_tool_column(measurements, tmp_path):
    """A MEASUREMENTS file with a 'tool' id column instead of the offsets, and --tool
    ID=x,y,z for each: the same calibration as the file with the offsets written out."""
    lines = measurements.read_text().splitlines()
    ids = {"0,0,-100": "T1", "100,0,-100": "T2", "0,100,-100": "T3"}
    rows = ["point,X,Y,Z,tool,range,azimuth,elevation,T_X,T_Y,T_Z"]
    for line in lines[1:]:
        c = line.split(",")
        key = ",".join(f"{float(v):g}" for v in c[4:7])
        rows.append(",".join([*c[:4], ids[key], *c[7:]]))
    by_id = tmp_path / "ids.csv"
    by_id.write_text("\n".join(rows) + "\n")
    tools = ["--tool", "T1=0,0,-100", "--tool", "T2=100,0,-100", "--tool", "T3=0,100,-100"]
    res = mtm("tracker", "calibrate", by_id, "--machine", MACHINE, "--json", *tools)
    assert res.exit_code == 0, res.output
    ref = mtm("tracker", "calibrate", measurements, "--machine", MACHINE, "--json")
    got, want = json.loads(res.stdout), json.loads(ref.stdout)
    assert got["parameters"] == want["parameters"]
    res = mtm("tracker", "calibrate", by_id, "--machine", MACHINE, *tools[:4])
    assert res.exit_code == 2
    assert res.output.strip().startswith(f"error: {by_id}, line ")
    assert "tool 'T3' has no offset" in res.output
    res = mtm("tracker", "calibrate", measurements, "--machine", MACHINE, "--tool", "T1=0,0")
    assert res.exit_code == 2 and res.output.startswith("error: --tool T1")


def test_known_pose_fixed_or_as_prior(measurements, tmp_path):
    """--pose: fixed (not identified, zero covariance) or, with the six u_* fields, a prior
    (the identified pose's u is then below the prior's)."""
    fields = "D_mm: -563.52\nL_mm: 194.37\nH_mm: 677.78\nalpha_deg: 0.0339\n"
    fields += "beta_deg: 0.0343\ndelta_deg: 59.4652\n"
    fixed = tmp_path / "pose.yaml"
    fixed.write_text("kind: tracker-pose\nversion: 1\n" + fields)
    res = mtm("tracker", "calibrate", measurements, "--machine", MACHINE, "--pose", fixed,
              "--json")  # fmt: skip
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["pose_source"] == "fixed" and doc["pose"]["D_mm"] == -563.52
    assert all(v == 0.0 for v in doc["pose_u"].values())
    prior = tmp_path / "prior.yaml"
    u = "u_D_mm: 0.01\nu_L_mm: 0.01\nu_H_mm: 0.01\nu_alpha_deg: 1e-4\nu_beta_deg: 1e-4\n"
    prior.write_text("kind: tracker-pose\nversion: 1\n" + fields + u + "u_delta_deg: 1e-4\n")
    res = mtm("tracker", "calibrate", measurements, "--machine", MACHINE, "--pose", prior,
              "--json")  # fmt: skip
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["pose_source"] == "prior"
    assert 0 < doc["pose_u"]["D_mm"] <= 0.01 and 0 < doc["pose_u"]["delta_deg"] <= 1e-4
    prior.write_text("kind: tracker-pose\nversion: 1\n" + fields + u)
    res = mtm("tracker", "calibrate", measurements, "--machine", MACHINE, "--pose", prior)
    assert res.exit_code == 2
    assert res.output.strip() == (
        f"error: {prior}: u_delta_deg: a pose prior needs all of u_D_mm, u_L_mm, u_H_mm, "
        "u_alpha_deg, u_beta_deg, u_delta_deg"
    )


def test_verify_lengths_from_a_tracker_calibration(measurements, tmp_path):
    """``mtm length predict``: each pair's length with the calibrated errors and u(L), U at
    k = 2 (the library's numbers); a reference gives e and E_n; no covariance is refused."""
    res = mtm("tracker", "calibrate", measurements, "--machine", MACHINE, "-o", tmp_path / "r.json")
    assert res.exit_code == 0, res.output
    pairs = tmp_path / "pairs.csv"
    pairs.write_text(
        "pair,end,X,Y,Z\nx,a,800,300,300\nx,b,1200,300,300\nd,a,850,150,250\nd,b,1150,450,350\n"
    )
    (tmp_path / "ref.csv").write_text("pair,length_mm,u_um\nx,400.0,0.5\nd,435.89,0.5\n")
    res = mtm("length", "predict", pairs, "--machine", MACHINE, "--params", tmp_path / "r.json",
              "--reference", tmp_path / "ref.csv", "--json")  # fmt: skip
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["kind"] == "length-prediction" and doc["k"] == 2.0
    assert [p["pair"] for p in doc["pairs"]] == ["x", "d"]
    m = Machine.load(MACHINE)
    pset = ParameterSet.load(tmp_path / "r.json", m)
    mm = pset.machine_for(m)
    q = np.array([[800, 300, 300], [1200, 300, 300], [850, 150, 250], [1150, 450, 350.0]])
    want = pair_lengths(mm, pset.vector_for(mm), pset.covariance, q[::2], q[1::2])
    for row, length, u in zip(doc["pairs"], want.predicted, want.u, strict=True):
        assert row["length_mm"] == pytest.approx(length, rel=1e-12)
        assert row["U_um"] == pytest.approx(2e3 * u, rel=1e-9)
        assert row["error_um"] == pytest.approx(1e3 * (length - row["reference_mm"]), rel=1e-9)
    bare = tmp_path / "bare.yaml"
    bare.write_text(
        "kind: parameter-set\nversion: 1\nmachine: three-axis-xfyz\n"
        "parameters:\n  - {name: E_XX1, value: 5.0, unit: µm}\n"
    )
    res = mtm("length", "predict", pairs, "--machine", MACHINE, "--params", bare)
    assert res.exit_code == 2
    assert res.output.strip() == f"error: {bare}: no covariance; u(L) needs the calibration's U_θ"
