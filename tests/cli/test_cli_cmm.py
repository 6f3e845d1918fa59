"""``mtm cmm simulate``, ``mtm cmm calibrate``, ``mtm gp``, ``mtm predict --probes``."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.cmm.files import load_plate, load_probes
from mtmetrology.cmm.simulate import simulate_ballplate
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

runner = CliRunner()
M = ["--machine", "cmm-moving-bridge"]
PROBES = {"P0": [0, 0, -150], "PX1": [50, 0, -150], "PY1": [0, 50, -150], "PY2": [0, -50, -150]}
TRUTH = {  # terms of the seed model, customary units (Chebyshev on the travel: µm, µrad)
    "E_XX1": ("µm", 6.0),
    "E_YY1": ("µm", -4.0),
    "E_ZZ1": ("µm", 3.0),
    "E_BY2": ("µrad", 6.0),
    "E_CX1": ("µrad", 8.0),
    "E_AZ1": ("µrad", -5.0),
    "E_C0X": ("µrad", 10.0),
}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("cmm")
    balls = [
        {"id": f"{3 * j + i:02d}", "x_mm": 266.0 * i, "y_mm": 266.0 * j, "z_mm": 0.0}
        for j in range(3)
        for i in range(3)
    ]
    docs = {
        "plate.yaml": {"kind": "ball-plate", "balls": balls, "u_mm": 0.0005},
        "probes.yaml": {
            "kind": "probe-set",
            "probes": [{"id": k, "offset_mm": v} for k, v in PROBES.items()],
        },
        "positions.yaml": {
            "kind": "ballplate-positions",
            "positions": [
                {"id": i, "origin_mm": o, "rotation_deg": r, "probes": list(PROBES)}
                for i, o, r in [
                    ("H", [330, 230, 150], [0, 0, 0]),
                    ("VX", [330, 500, 10], [90, 0, 0]),
                    ("VY", [600, 230, 10], [90, 0, 90]),
                    ("T", [330, 230, 120], [30, 0, 0]),
                ]
            ],
        },
        "truth.yaml": {
            "kind": "parameter-set",
            "version": 1,
            "machine": "cmm-moving-bridge",
            "parameters": [{"name": n, "value": v, "unit": u} for n, (u, v) in TRUTH.items()],
        },
    }
    out = {}
    for name, doc in docs.items():
        (d / name).write_text(yaml.safe_dump(doc, allow_unicode=True), encoding="utf-8")
        out[name.split(".")[0]] = d / name
    out["dir"] = d
    res = runner.invoke(
        app,
        [
            "cmm", "simulate", *M, "--params", str(out["truth"]), "--plate",
            str(out["plate"]), "--probes", str(out["probes"]), "--positions",
            str(out["positions"]), "--seed", "3", "-o", str(d / "records.csv"),
        ],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    out["records"] = d / "records.csv"
    return out


def _calibrate(files, records, output, *extra):
    return runner.invoke(
        app,
        [
            "cmm", "calibrate", str(records), *M, "--plate", str(files["plate"]),
            "--probes", str(files["probes"]), "-o", str(output), *extra,
        ],
    )  # fmt: skip


def test_simulated_records_match_the_library(files):
    """The CLI writes what :func:`simulate_ballplate` returns (same seed), rounded to 1 nm."""
    rows = list(csv.DictReader(files["records"].open()))
    assert list(rows[0]) == ["position", "ball", "probe", "X", "Y", "Z"]
    assert len(rows) == 4 * 9 * len(PROBES)
    from mtmetrology.cmm.files import load_positions

    m = Machine.load("cmm-moving-bridge")
    pset = ParameterSet.load(files["truth"], m)
    mm = pset.machine_for(m)
    probes = load_probes(files["probes"])
    camp = simulate_ballplate(
        mm,
        pset.vector_for(mm),
        load_plate(files["plate"]),
        load_positions(files["positions"], probes),
        probes,
        sigma=0.0005,
        seed=3,
    )
    got = np.array([[float(r[a]) for a in "XYZ"] for r in rows])
    np.testing.assert_allclose(got, camp.records.readings, rtol=0, atol=1e-6)


def test_calibrate_then_predict_recovers_truth(files):
    """Seed model truth: the result JSON is a parameter set with U1/U2/U3; `mtm predict
    --probes` compensates the records onto the true plate geometry."""
    out = files["dir"] / "result.json"
    res = _calibrate(files, files["records"], out)
    assert res.exit_code == 0, res.output
    doc = json.loads(out.read_text())
    assert doc["kind"] == "ballplate-calibration" and doc["machine"] == "cmm-moving-bridge"
    assert {"U1_um", "U2_um", "U3_um"} <= set(doc["uncertainty"])
    assert doc["fit"]["rank"] == doc["fit"]["n_unknowns"]
    values = {p["name"]: (p["value"], p["u"]) for p in doc["parameters"]}
    for name, (_, true) in TRUTH.items():
        v, u = values[name]
        assert abs(v - true) < 4.0 * u + 1e-3, name  # |z| < 4 for each recovered term
    pred = files["dir"] / "pred.csv"
    res = runner.invoke(
        app,
        [
            "predict", *M, "--params", str(out), "--probes", str(files["probes"]),
            str(files["records"]), "-o", str(pred),
        ],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    rows = list(csv.DictReader(pred.open()))
    assert list(rows[0])[-3:] == ["x", "y", "z"]
    h = [r for r in rows if r["position"] == "H" and r["probe"] == "P0"]
    xyz = np.array([[float(r[c]) for c in "xyz"] for r in h])
    d = np.linalg.norm(xyz[0] - xyz[8])  # balls 00 and 08: the plate diagonal
    assert d == pytest.approx(np.hypot(532.0, 532.0), abs=0.003)  # plate u, noise


def test_auto_model_reports_scores(files):
    out = files["dir"] / "auto.json"
    res = _calibrate(files, files["records"], out, "--model", "auto", "--candidates", "seed,full-1")
    assert res.exit_code == 0, res.output
    sel = json.loads(out.read_text())["model_selection"]
    assert [s["model"] for s in sel["scores"]] == ["seed", "full-1"]
    assert all(len(s["rms_um"]) == 4 for s in sel["scores"])  # held-out RMS per position
    assert sel["chosen"] in {s["model"] for s in sel["scores"] if s["eligible"]}
    # the console reports every candidate's score and AIC (issue 18 §3), as in the JSON
    lines = {ln.split()[0]: ln for ln in res.stderr.splitlines() if ln.startswith("  ")}
    for s in sel["scores"]:
        line = lines[s["model"]]
        assert f"held-out median {s['median_rms_um']:.3g} µm, AIC {s['aic']:.1f}" in line
        assert ("[chosen" in line) == (s["model"] == sel["chosen"])


def test_auto_with_a_too_small_sigma_does_not_advise_auto(files):
    """Issue 30: σ stated 10x too small makes every candidate's χ² significant; the warning
    after ``--model auto`` points to what the user has not tried (more candidates, σ)."""
    out = files["dir"] / "auto-small-sigma.json"
    res = _calibrate(
        files, files["records"], out, "--model", "auto", "--candidates", "seed,full-1",
        "--sigma-um", "0.05",
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    doc = json.loads(out.read_text())
    assert doc["fit"]["chi2_p_value"] < 0.01
    assert doc["adequacy"]["significant"] and doc["adequacy"]["scaled"]
    warning = [ln for ln in res.stderr.splitlines() if ln.startswith("warning: ")]
    assert len(warning) == 1 and warning[0].startswith(f"warning: {doc['adequacy']['message']}")
    assert "--model auto" not in warning[0] and "--candidates" in warning[0]
    plain = _calibrate(files, files["records"], out, "--sigma-um", "0.05")
    assert any("compare models with --model auto" in ln for ln in plain.stderr.splitlines())


def test_gp_fit_predict_and_predict_with_gp_file(files):
    gp = files["dir"] / "gp.json"
    args = ["--plate", str(files["plate"]), "--probes", str(files["probes"])]
    res = runner.invoke(app, ["gp", "fit", str(files["records"]), *M, *args, "-o", str(gp)])
    assert res.exit_code == 0, res.output
    assert json.loads(gp.read_text())["kind"] == "gp-error-model"
    out = files["dir"] / "gp.csv"
    res = runner.invoke(
        app,
        [
            "gp", "predict", str(files["records"]), *M, "--model", str(gp), "--probes",
            str(files["probes"]), "-o", str(out),
        ],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    rows = list(csv.DictReader(out.open()))
    assert list(rows[0])[-6:] == ["x", "y", "z", "u_x_um", "u_y_um", "u_z_um"]
    out2 = files["dir"] / "gp2.csv"
    res = runner.invoke(
        app,
        [
            "predict", *M, "--params", str(gp), "--probes", str(files["probes"]),
            str(files["records"]), "-o", str(out2),
        ],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    a = [[r[c] for c in "xyz"] for r in rows]
    b = [[r[c] for c in "xyz"] for r in csv.DictReader(out2.open())]
    assert a == b


def _edit(files, name, transform):
    lines = files["records"].read_text().splitlines()
    path = files["dir"] / name
    path.write_text("\n".join(transform(lines)) + "\n")
    return path


def _with_nan(line):
    cells = line.split(",")
    cells[3] = "nan"
    return ",".join(cells)


@pytest.mark.parametrize(
    ("case", "transform", "named"),
    [
        ("ball", lambda ls: [ls[0], ls[1].replace(",00,", ",99,", 1), *ls[2:]],
         ", line 2: ball '99' is not on the plate"),
        ("probe", lambda ls: [ls[0], ls[1].replace(",P0,", ",PZ,", 1), *ls[2:]],
         ", line 2: probe 'PZ' is not in the probe set"),
        ("few", lambda ls: [*ls, "X,00,P0,400,300,200", "X,01,P0,500,300,200"],
         ": position 'X' has 2 distinct"),
        ("nan", lambda ls: [ls[0], _with_nan(ls[1]), *ls[2:]], ", line 2: column 'X' is 'nan'"),
    ],
)  # fmt: skip
def test_bad_records_exit_2_and_write_nothing(files, case, transform, named):
    """A ball not on the plate, a probe not in the set, a position with 2 balls, NaN: the
    error names the file, the line and the ball, probe, position or column."""
    bad = _edit(files, f"bad-{case}.csv", transform)
    out = files["dir"] / f"bad-{case}.json"
    res = _calibrate(files, bad, out)
    assert res.exit_code == 2
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"error: {bad}{named}"), lines
    assert not out.exists()


def test_budget_command(files):
    spec = {
        "kind": "ballplate-budget", "length_mm": 532.0,
        "observed": {"value_mm": 532.018, "s_um": 2.0, "n": 6},
        "verification_um": 1.0, "indication_resolution_um": 0.1, "probe_reproducibility_um": 0.5,
        "air": {"temperature_C": 20.6, "pressure_Pa": 101325, "humidity_percent": 51},
        "hygrometer_U_percent": 1.1, "humidity_resolution_percent": 1.0, "barometer_U_Pa": 20,
        "pressure_resolution_Pa": 1, "air_thermometer_U_K": 0.02,
        "air_thermometer_resolution_K": 0.01, "misalignment_um": 50, "part_temperature_C": 20.6,
        "part_thermometer_U_K": 0.02, "temperature_spread_K": 0.5, "cte_per_K": 11.5e-6,
        "cte_halfwidth_per_K": 1e-6,
    }  # fmt: skip
    path = files["dir"] / "budget.yaml"
    path.write_text(yaml.safe_dump(spec))
    out = files["dir"] / "budget.json"
    res = runner.invoke(app, ["cmm", "budget", str(path), "-o", str(out)])
    assert res.exit_code == 0, res.output
    o = json.loads(out.read_text())["outputs"][0]
    assert o["name"] == "l_x" and o["U"] == pytest.approx(o["k"] * o["u"])
    spec["cte_per_K"] = -1.0
    path.write_text(yaml.safe_dump(spec))
    res = runner.invoke(app, ["cmm", "budget", str(path), "-o", str(out) + "x"])
    assert res.exit_code == 2 and "cte_per_K" in res.output


def test_predict_knows_the_gp_kind_without_importing_the_gp_machinery():
    """mtm predict checks a file's kind before importing scikit-learn: the kind it checks
    is the one GP model files carry."""
    import subprocess
    import sys

    from mtmetrology.cli.predict import GP_KIND
    from mtmetrology.cmm.gp import KIND

    assert GP_KIND == KIND
    code = "import sys, mtmetrology.cli.predict; print('sklearn' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_predict_refuses_a_probe_column_without_probes(files):
    """Records with a 'probe' column and no --probes were compensated with the tool (0, 0, 0),
    150 mm off, exit 0 (issue 18 §3): refuse, naming the column and the option."""
    out = files["dir"] / "pred-noprobes.csv"
    res = runner.invoke(app, ["predict", *M, str(files["records"]), "-o", str(out)])
    assert res.exit_code == 2
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith(f"error: {files['records']}: column 'probe'")
    assert "--probes" in lines[0].split("column 'probe'")[1]
    assert not out.exists()


def test_calibrate_history_records_the_result_in_the_same_step(files, tmp_path, monkeypatch):
    """--history: the run in the database is the written result; the same result a second
    time is refused (exit 2) before its output is written."""
    from mtmetrology.history import list_runs, open_history, show_run

    monkeypatch.setenv("MTMETROLOGY_DB", str(tmp_path / "history.sqlite"))
    out = tmp_path / "result.json"
    res = _calibrate(files, files["records"], out, "--history")
    assert res.exit_code == 0, res.output
    engine = open_history()
    (run,) = list_runs(engine)
    record = show_run(engine, run.id)
    doc = json.loads(out.read_text())
    assert record.result == doc
    assert [p["value"] for p in record.parameters] == [p["value"] for p in doc["parameters"]]
    assert str(files["records"]) in record.input_hashes
    again = tmp_path / "again.json"
    res = _calibrate(files, files["records"], again, "--history")
    assert res.exit_code == 2
    assert "already recorded as calibration run 1" in res.stderr
    assert not again.exists()
