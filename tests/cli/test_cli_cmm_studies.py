"""``mtm cmm``: compare, source-gp, selfcal-design (thin commands over the cmm library)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.cmm.files import (
    BallPlateRecords,
    load_plate,
    load_probes,
    read_records,
    write_records,
)
from mtmetrology.cmm.heldout import compare_held_out
from mtmetrology.cmm.selfcal import selfcal_design
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

runner = CliRunner()
M = ["--machine", "cmm-moving-bridge"]
PROBES = {"P0": [0, 0, -150], "PX1": [50, 0, -150], "PY1": [0, 50, -150]}
TRUTH = {"E_XX1": ("µm", 6.0), "E_YY1": ("µm", -4.0), "E_CX1": ("µrad", 8.0)}
POSITIONS = [
    ("H", [330, 230, 150], [0, 0, 0]),
    ("VX", [330, 500, 10], [90, 0, 0]),
    ("VY", [600, 230, 10], [90, 0, 90]),
    ("T", [330, 230, 120], [30, 0, 0]),
]


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("cmmcmp")
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
                for i, o, r in POSITIONS
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
        out[name.split(".")[0]] = str(d / name)
    out["records"] = str(d / "records.csv")
    res = runner.invoke(
        app,
        [
            "cmm", "simulate", *M, "--params", out["truth"], "--plate", out["plate"],
            "--probes", out["probes"], "--positions", out["positions"], "--seed", "4",
            "-o", out["records"],
        ],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    out["dir"] = d
    return out


def _args(files, *extra):
    return [
        "cmm", "compare", files["records"], *M, "--plate", files["plate"], "--probes",
        files["probes"], "--model", "seed", *extra,
    ]  # fmt: skip


def test_compare_writes_json_and_report_equal_to_the_library(files):
    out, rep = files["dir"] / "cmp.json", files["dir"] / "cmp.html"
    res = runner.invoke(
        app, _args(files, "--held-out", "T", "-o", str(out), "--json", "--report", str(rep))
    )
    assert res.exit_code == 0, res.output
    doc = json.loads(out.read_text())
    assert doc["kind"] == "cmm-held-out-comparison" and doc["held_out"] == ["T"]
    lib = compare_held_out(
        Machine.load("cmm-moving-bridge"),
        read_records(files["records"]),
        load_plate(files["plate"]),
        load_probes(files["probes"]),
        ["T"],
        sigma=0.0005,
        kinematic_model="seed",
    )
    assert doc["table"] == lib.to_dict()["table"]
    rows = {r["model"].split(" ")[0]: r for r in doc["table"]}
    assert rows["kinematic"]["rms_error_um"] < rows["uncompensated"]["rms_error_um"]
    assert rep.stat().st_size > 0


@pytest.mark.parametrize(
    ("extra", "named"),
    [
        (["--held-out", "Q"], "--held-out 'Q'"),
        (["--held-out", "H", "--held-out", "VX", "--held-out", "VY", "--held-out", "T"],
         "--held-out"),
        (["--held-out", "T", "--kernel", "cubic"], "--kernel 'cubic'"),
        (["--held-out", "T", "--sigma-um", "-1"], "--sigma-um"),
    ],
)  # fmt: skip
def test_bad_input_exits_2_with_one_line_and_writes_nothing(files, extra, named):
    out = files["dir"] / "never.json"
    res = runner.invoke(app, _args(files, *extra, "-o", str(out)))
    assert res.exit_code == 2, res.output
    lines = [ln for ln in res.output.splitlines() if ln.startswith("error:")]
    assert len(lines) == 1 and named in lines[0]
    assert not out.exists()


def test_source_gp_command_prints_the_reproduced_hyperparameters(tmp_path):
    out = tmp_path / "gp.json"
    rep = tmp_path / "gp.html"
    res = runner.invoke(app, ["cmm", "source-gp", "-o", str(out), "--report", str(rep)])
    assert res.exit_code == 0, res.output
    assert "0.01065" in rep.read_text(encoding="utf-8")
    doc = json.loads(out.read_text())
    assert doc["zero_mean"]["hyperparameters"] == pytest.approx(
        [-2.013713, -4.082864, -4.485944], abs=5e-7
    )
    assert 0.010 < doc["max_difference"] < 0.011


def test_selfcal_design_command_equals_the_library(tmp_path):
    machine = Path(__file__).resolve().parents[2] / "examples/cmm/cmm-salacheep-xyz.yaml"
    out = tmp_path / "design.json"
    res = runner.invoke(
        app,
        ["cmm", "selfcal-design", "--machine", str(machine), "--locations", "L0,L1", "-o",
         str(out), "--report", str(tmp_path / "design.html")],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    doc = json.loads(out.read_text())
    lib = selfcal_design(Machine.load(machine), ["L0", "L1"], sigma=0.0005, seed=0)
    assert doc == json.loads(json.dumps(lib.to_dict()))
    assert doc["full_rank"] is False and doc["U_full_um"] is None
    assert "stylus centroid" in (tmp_path / "design.html").read_text(encoding="utf-8")


def test_selfcal_design_refuses_an_unknown_location(tmp_path):
    out = tmp_path / "never.json"
    res = runner.invoke(
        app,
        ["cmm", "selfcal-design", *M, "--locations", "L0,L7", "-o", str(out)],
    )
    assert res.exit_code == 2
    assert [ln for ln in res.output.splitlines() if ln.startswith("error:")] == [
        "error: location 'L7': use L0, L1, L2"
    ]
    assert not out.exists()


@pytest.fixture(scope="module")
def qualification(files):
    """Readings of a sphere at (600, 500, 300) mm with each stylus, on the true machine."""
    base = Machine.load("cmm-moving-bridge")
    truth = ParameterSet.load(files["truth"], base)
    machine = truth.machine_for(base)
    ids = list(PROBES) * 2
    tools = np.array([PROBES[k] for k in ids], dtype=float)
    sphere = np.array([600.0, 500.0, 300.0])
    q = machine.inverse(np.tile(sphere, (len(ids), 1)), sphere - tools,
                        truth.vector_for(machine), tool=tools)  # fmt: skip
    q = q + 0.0005 * np.random.default_rng(8).standard_normal(q.shape)
    path = files["dir"] / "qualification.csv"
    rec = BallPlateRecords(("Q",) * len(ids), ("S",) * len(ids), tuple(ids), q,
                           np.arange(len(ids)) + 2)  # fmt: skip
    write_records(path, rec)
    return str(path)


def test_calibrate_estimates_probes_and_refuses_a_bad_length(files, qualification):
    out = files["dir"] / "probecal.json"
    args = [
        "cmm", "calibrate", files["records"], *M, "--plate", files["plate"], "--probes",
        files["probes"], "--qualification", qualification,
    ]  # fmt: skip
    rep = files["dir"] / "probecal.html"
    res = runner.invoke(
        app, [*args, "--length", "00,08,752.362,0.2", "-o", str(out), "--report", str(rep)]
    )
    assert res.exit_code == 0, res.output
    assert "PX1" in rep.read_text(encoding="utf-8")
    doc = json.loads(out.read_text())
    assert doc["kind"] == "cmm-probe-plate-calibration" and doc["plate"] == "one length 00-08"
    corr = np.array([p["correction_um"] for p in doc["probes"].values()])
    np.testing.assert_allclose(corr.sum(axis=0), 0.0, atol=1e-6)  # the centroid constraint
    bad = files["dir"] / "never.json"
    res = runner.invoke(app, [*args, "--length", "00,08,abc", "-o", str(bad)])
    assert res.exit_code == 2 and not bad.exists()
    errors = [ln for ln in res.output.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "--length '00,08,abc'" in errors[0]
