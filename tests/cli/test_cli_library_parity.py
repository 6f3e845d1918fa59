"""Every command's output equals, field for field, what the library call a notebook makes
with the same inputs gives (issue 20): the command line only parses, calls and prints.

Each case writes its input files, runs the command, and makes the one library call; the
command's JSON (or CSV columns) must equal the result's ``to_dict()``.  A case fails when
the command composes anything of its own (a field added, a value recomputed, another
default).
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.uncertainty.conformity import Tolerance
from mtmetrology.uncertainty.coverage import unstated_coverage

runner = CliRunner()
MACHINE = Machine.load("five-axis-wcbxfzyst")
# Table 7-1 gauge-block readings (Sepahi Boroujeni (2021)), the two faces of a length.
TASK_POINTS = """point,X,Y,Z,B,C,end
p1,-138.5650,94.6560,196.2320,-42,-293,1
p2,-61.2880,48.3440,246.8170,-64,-124,2
"""


def _params(path, seed=1):
    rng = np.random.default_rng(seed)
    a = MACHINE.parameter_scales[:, None] * rng.normal(size=(13, 13))
    ParameterSet(
        MACHINE.parameter_names,
        rng.normal(size=13) * MACHINE.parameter_scales * 3,
        MACHINE.parameter_units,
        covariance=a @ a.T,
        machine=MACHINE.name,
    ).save(path)
    return path


def _json(args: list[str], json_output: bool = True) -> dict | None:
    result = runner.invoke(app, [str(a) for a in args])
    assert result.exit_code == 0, result.output
    return json.loads(result.stdout) if json_output else None


def _plain(document: dict) -> dict:
    """The document as JSON carries it (tuples become lists, numpy floats floats)."""
    return json.loads(json.dumps(document, allow_nan=False))


def case_task(tmp_path):
    from mtmetrology.omm.task_request import task_uncertainty_from_files

    (tmp_path / "points.csv").write_text(TASK_POINTS, encoding="utf-8")
    params = _params(tmp_path / "params.json")
    points = tmp_path / "points.csv"
    lt = _params(tmp_path / "lt.json", seed=2)
    cli = _json(
        [
            *("task", "uncertainty", points, "--machine", MACHINE.name, "--params", params),
            *("--feature", "length", "--long-term", lt, "--tolerance", "100,-0.01,0.01"),
            *("--guard-band-factor", "0.5", "--json"),
        ]
    )
    library = task_uncertainty_from_files(
        points,
        MACHINE.name,
        params,
        "length",
        long_term=lt,
        tolerance="100,-0.01,0.01",
        guard_band_factor=0.5,
    )
    # the parts the command used to compose itself are there to compare
    assert cli["source"]["long_term"] == str(lt)
    assert cli["decision"]["guard_band_factor"] == 0.5
    return cli, library.to_dict()


def case_fit(tmp_path):
    from mtmetrology.fitting.element_fit import fit_points_file

    rng = np.random.default_rng(3)
    angle = rng.uniform(0.0, 2.0 * np.pi, 20)
    r = 12.0 + 0.002 * rng.uniform(-0.5, 0.5, 20)
    path = tmp_path / "ring.csv"
    rows = "\n".join(
        f"{x:.9f},{y:.9f},0" for x, y in zip(r * np.cos(angle), r * np.sin(angle), strict=True)
    )
    path.write_text("x,y,z\n" + rows + "\n", encoding="utf-8")
    cli = _json(
        [
            *("fit", "circle", path, "--method", "minimum-zone", "--tip-radius", "1"),
            *("--inside", "--json"),
        ]
    )
    library = fit_points_file("circle", path, method="minimum-zone", tip_radius=1.0, inside=True)
    return cli, library.to_dict()


def case_predict(tmp_path):
    from mtmetrology.io import read_csv_table
    from mtmetrology.kinematics.compensation import compensate
    from mtmetrology.kinematics.readings_table import readings_from_table

    records = tmp_path / "r.csv"
    records.write_text("X,Y,Z,B,C\n100,0,100,0,0\n-50,20,80,30,45\n", encoding="utf-8")
    params = _params(tmp_path / "params.json")
    result = runner.invoke(
        app, ["predict", str(records), "--machine", MACHINE.name, "--params", str(params), "--u"]
    )
    assert result.exit_code == 0, result.output
    rows = list(csv.DictReader(io.StringIO(result.stdout)))
    cli = {
        "points": [[float(r[c]) for c in "xyz"] for r in rows],
        "u_um": [[float(r[f"u_{c}_um"]) for c in "xyz"] for r in rows],
    }
    pset = ParameterSet.load(params, MACHINE)
    machine = pset.machine_for(MACHINE)
    q = readings_from_table(machine, read_csv_table(records))
    doc = compensate(machine, q, pset.vector_for(machine), pset.covariance, with_u=True).to_dict()
    # the CSV carries 6 decimals of mm and of µm
    library = {
        "points": np.round(doc["points"], 6).tolist(),
        "u_um": np.round(np.asarray(doc["u"]) * 1e3, 6).tolist(),
    }
    return cli, library


def case_budget(tmp_path):
    from mtmetrology.budgets.iso15530 import iso15530_3_budget
    from mtmetrology.uncertainty.conformity import Tolerance

    values = 50.0 + 0.001 * np.random.default_rng(4).normal(size=20)
    runs = tmp_path / "runs.csv"
    runs.write_text("value\n" + "\n".join(f"{v:.6f}" for v in values) + "\n", "utf-8")
    cli = _json(
        [
            *("budget", "iso15530-3", runs, "--calibrated", "50.0005", "--u-cal", "0.4"),
            *("--u-w", "0.3", "--tolerance", "50,-0.01,0.01", "--json"),
        ]
    )
    library = iso15530_3_budget(
        np.round(values, 6),
        calibrated=50.0005,
        u_cal=0.4e-3,
        u_w=0.3e-3,
        tolerance=Tolerance.parse("50,-0.01,0.01"),
        name=str(runs),
        provenance={"runs": str(runs)},
    )
    return cli, library.to_dict()


def case_hysteresis(tmp_path):
    from mtmetrology.omm.repeatability_records import hysteresis_from_file

    rng = np.random.default_rng(5)
    rows = [
        f"{psi},{condition},{25.0 + 0.001 * rng.normal():.7f}"
        for psi in (0, 90, 180, 270)
        for condition in ("direct", "hysteresis")
        for _ in range(4)
    ]
    records = tmp_path / "ring.csv"
    records.write_text("psi,condition,r\n" + "\n".join(rows) + "\n", encoding="utf-8")
    cli = _json(["repeatability", "hysteresis", records, "--p", "0.9", "--json"])
    return cli, hysteresis_from_file(records, p=0.9).to_dict()


ML_STATIONS = """kind: multilateration-stations
version: 1
stations:
  - {name: S1, position_mm: [750, 50, 30], dead_path_mm: 100}
  - {name: S2, position_mm: [1250, 60, 40], dead_path_mm: 200}
  - {name: S3, position_mm: [760, 560, 20], dead_path_mm: 300}
  - {name: S4, position_mm: [1240, 540, 50], dead_path_mm: 400}
"""


def case_multilateration(tmp_path):
    from mtmetrology.multilateration.requests import calibrate_multilateration_file

    (tmp_path / "stations.yaml").write_text(ML_STATIONS, encoding="utf-8")
    lengths = tmp_path / "lengths.csv"
    result = runner.invoke(
        app,
        [
            *("multilateration", "simulate", "--machine", "three-axis-xfyz", "--grid", "4,4,4"),
            *("--stations", str(tmp_path / "stations.yaml"), "--seed", "1", "-o", str(lengths)),
        ],
    )
    assert result.exit_code == 0, result.output
    cli = _json(
        [
            *("multilateration", "calibrate", lengths, "--machine", "three-axis-xfyz"),
            *("--mc", "4", "--seed", "3", "--json"),
        ]
    )
    assert cli["provenance"]["map_monte_carlo"]["trials"] == 4
    library = calibrate_multilateration_file(lengths, Machine.load("three-axis-xfyz"), mc=4, seed=3)
    return cli, library.to_dict()


def case_tracker(tmp_path):
    from mtmetrology.tracker import calibrate, files, read_measurements

    (tmp_path / "tools.yaml").write_text(
        "kind: tracker-tools\nversion: 1\n"
        "tools_mm: [[0, 0, -100], [100, 0, -100], [0, 100, -100]]\n",
        encoding="utf-8",
    )
    meas = tmp_path / "meas.csv"
    result = runner.invoke(
        app,
        [
            *("tracker", "simulate", "--machine", "three-axis-xfyz", "--tools"),
            *(str(tmp_path / "tools.yaml"), "--seed", "4", "-o", str(meas)),
            *("--mesh", "800:1200:100,100:500:200,200:400:100"),
        ],
    )
    assert result.exit_code == 0, result.output
    cli = _json(
        [
            "tracker",
            "calibrate",
            meas,
            "--machine",
            "three-axis-xfyz",
            "--angle-urad",
            "15",
            "--json",
        ]
    )
    library = calibrate(
        Machine.load("three-axis-xfyz"),
        read_measurements(meas),
        noise=files.noise(15.0),
        conditions=files.load_conditions(None),
    )
    return cli, library.to_dict()


def case_simulate_length(tmp_path):
    from mtmetrology.samba import simulate_length_check

    out = tmp_path / "gauge.csv"
    result = runner.invoke(
        app,
        [
            *("length", "simulate", "--machine", MACHINE.name, "--end-a", "-100,-100,40"),
            *("--end-b", "100,100,40", "--pairs", "6", "--noise-um", "0.5", "--seed", "5"),
            *("-o", str(out)),
        ],
    )
    assert result.exit_code == 0, result.output
    rows = list(csv.reader(io.StringIO(out.read_text(encoding="utf-8"))))
    cli = {"header": rows[0], "lines": rows[1:]}
    check = simulate_length_check(
        MACHINE, None, (-100, -100, 40), (100, 100, 40), pairs=6, noise=0.5e-3, seed=5
    )
    return cli, {"header": list(check.header), "lines": check.lines()}


def case_repeatability_fit(tmp_path):
    from mtmetrology.omm.repeatability_records import fit_repeatability_file

    rng = np.random.default_rng(6)
    rows = ["target,phi,theta,B,C,X_T,Y_T,Z_T,i,j,k,X,Y,Z,time"]
    for t in range(45):
        phi, theta = np.radians(rng.uniform(0, 90)), np.radians(rng.uniform(0, 360))
        b, c = rng.uniform(-90, 90), rng.uniform(-180, 180)
        target = rng.uniform(-200, 200, 3)
        n = (np.sin(phi) * np.sin(theta), np.sin(phi) * np.cos(theta), np.cos(phi))
        for s in range(6):
            p = target + rng.normal(0, 0.001, 3)
            rows.append(
                f"T{t},{np.degrees(phi)},{np.degrees(theta)},{b},{c},{target[0]},{target[1]},"
                f"{target[2]},{-n[0]},{-n[1]},{-n[2]},{p[0]:.6f},{p[1]:.6f},{p[2]:.6f},{s}"
            )
    records = tmp_path / "records.csv"
    records.write_text("\n".join(rows) + "\n", encoding="utf-8")
    cli = _json(
        [
            *("repeatability", "fit", records, "-o", tmp_path / "R.json"),
            *("--allow-few-targets", "--window", "3", "--seed", "2", "--json"),
        ]
    )
    library = fit_repeatability_file(records, allow_few_targets=True, window=3, seed=2)
    return cli, library.to_dict()


def _ballplate_files(tmp_path):
    """Plate, probe set, positions and simulated records of a 3 x 3 ball plate in 4
    positions on the moving-bridge CMM."""
    import yaml

    probes = {"P0": [0, 0, -150], "PX1": [50, 0, -150], "PY1": [0, 50, -150]}
    balls = [
        {"id": f"{3 * j + i:02d}", "x_mm": 266.0 * i, "y_mm": 266.0 * j, "z_mm": 0.0}
        for j in range(3)
        for i in range(3)
    ]
    poses = [
        ("H", [330, 230, 150], [0, 0, 0]),
        ("VX", [330, 500, 10], [90, 0, 0]),
        ("VY", [600, 230, 10], [90, 0, 90]),
        ("T", [330, 230, 120], [30, 0, 0]),
    ]
    docs = {
        "plate": {"kind": "ball-plate", "balls": balls, "u_mm": 0.0005},
        "probes": {
            "kind": "probe-set",
            "probes": [{"id": k, "offset_mm": v} for k, v in probes.items()],
        },
        "positions": {
            "kind": "ballplate-positions",
            "positions": [
                {"id": i, "origin_mm": o, "rotation_deg": r, "probes": list(probes)}
                for i, o, r in poses
            ],
        },
    }
    path = {}
    for name, doc in docs.items():
        path[name] = tmp_path / f"{name}.yaml"
        path[name].write_text(yaml.safe_dump(doc), encoding="utf-8")
    path["records"] = tmp_path / "records.csv"
    result = runner.invoke(
        app,
        [
            str(a)
            for a in [
                *("cmm", "simulate", "--machine", "cmm-moving-bridge", "--plate"),
                *(path["plate"], "--probes", path["probes"], "--positions"),
                *(path["positions"], "--seed", "3", "-o", path["records"]),
            ]
        ],
    )
    assert result.exit_code == 0, result.output
    return path


def case_ballplate(tmp_path):
    from mtmetrology.cmm.requests import calibrate_ballplate_files

    path = _ballplate_files(tmp_path)
    cli = _json(
        [
            *("cmm", "calibrate", path["records"], "--machine", "cmm-moving-bridge"),
            *("--plate", path["plate"], "--probes", path["probes"]),
            *("-o", tmp_path / "cal.json", "--sigma-um", "0.6", "--seed", "1", "--json"),
        ]
    )
    library = calibrate_ballplate_files(
        path["records"], "cmm-moving-bridge", path["plate"], path["probes"], sigma=0.6e-3, seed=1
    )
    return cli, library.to_dict()


def case_cmm_compare(tmp_path):
    from mtmetrology.cmm.files import load_plate, load_probes, read_records
    from mtmetrology.cmm.heldout import compare_held_out

    path = _ballplate_files(tmp_path)
    cli = _json(
        [
            *("cmm", "compare", path["records"], "--machine", "cmm-moving-bridge"),
            *("--plate", path["plate"], "--probes", path["probes"]),
            *("--held-out", "VY", "--held-out", "T"),
            *("--model", "seed", "--sigma-um", "0.6", "--json"),
        ]
    )
    plate, probes = load_plate(path["plate"]), load_probes(path["probes"])
    library = compare_held_out(
        Machine.load("cmm-moving-bridge"),
        read_records(path["records"], plate, probes),
        plate,
        probes,
        ["VY", "T"],
        sigma=0.6e-3,
        kinematic_model="seed",
    )
    return cli, library.to_dict()


def case_design_compare(tmp_path):
    from mtmetrology.design.compare import compare_strategies
    from mtmetrology.design.inputs import load_balls, read_indexations

    balls = tmp_path / "balls.yaml"
    balls.write_text(
        'kind: samba-balls\nballs:\n  - {id: "1", centre_mm: [-80, -40, 100]}\n',
        encoding="utf-8",
    )
    pairs = tmp_path / "pairs.csv"
    pairs.write_text(
        "B,C\n" + "".join(f"{b},{c}\n" for b in range(-90, 91, 30) for c in range(0, 360, 45)),
        encoding="utf-8",
    )
    cli = _json(
        [
            *("samba", "compare-plans", "--machine", MACHINE.name, "--model", "13", "--balls"),
            *(balls, "--indexations", pairs, "--n-balls", "1", "--k", "3", "--starts", "1"),
            *("--criterion", "D", "--sigma-um", "0.8", "--seed", "5", "--json"),
        ]
    )
    spec = load_balls(balls)
    library = compare_strategies(
        Machine.load(MACHINE.name, "13"),
        read_indexations(pairs),
        ([b.id for b in spec.balls], [b.centre_mm for b in spec.balls]),
        n_balls=[1],
        ks=[3.0],
        criteria=["D"],
        bar=spec.scale_bar,
        sigma_mm=0.8e-3,
        starts=1,
        seed=5,
    )
    return cli, library.to_dict()


def case_volumetric_map(tmp_path):
    from mtmetrology.budgets.volumetric_map import load_map, volumetric_map_budget
    from mtmetrology.io import read_csv_table

    machine = Machine.load("three-axis-xfyz")
    rng = np.random.default_rng(7)
    a = machine.parameter_scales[:, None] * rng.normal(size=(machine.n_params,) * 2)
    params = tmp_path / "params.json"
    ParameterSet(
        machine.parameter_names,
        rng.normal(size=machine.n_params) * machine.parameter_scales,
        machine.parameter_units,
        covariance=1e-2 * a @ a.T,
        machine=machine.name,
    ).save(params)
    t = np.linspace(0.0, 2.0 * np.pi, 12, endpoint=False)
    rows = ["x,y,z,cycle"]
    for cycle in range(3):
        q = np.c_[1000 + 40 * np.cos(t), 300 + 40 * np.sin(t), np.full(12, 300.0)]
        xyz = machine.forward(q + rng.normal(0.0, 1e-3, q.shape))
        rows += [f"{x:.6f},{y:.6f},{z:.6f},{cycle}" for x, y, z in xyz]
    points = tmp_path / "points.csv"
    points.write_text("\n".join(rows) + "\n", encoding="utf-8")
    cli = _json(
        [
            *("budget", "volumetric-map", points, "--machine", machine.name),
            *("--params", params, "--feature", "circle", "--probe-u", "2"),
            *("--tolerance", "diameter=80,-0.01,0.01", "--json"),
        ]
    )
    table = read_csv_table(points)
    xyz = table.vectors("xyz")
    library = volumetric_map_budget(
        xyz,
        load_map(machine, params, xyz),
        "circle",
        cycles=table.strings("cycle"),
        machine=machine.name,
        probe_error=2e-3,
        tolerances={"diameter": Tolerance.parse("80,-0.01,0.01")},
        provenance={"points": str(points), "params": str(params)},
    )
    return cli, library.to_dict()


def case_validate_task(tmp_path):
    from mtmetrology.omm.validation_request import validate_gauge_from_files

    params = _params(tmp_path / "params.json")
    lt = _params(tmp_path / "lt.json", seed=2)
    sides = {}
    for name, x, rows in (("a", -75.0, ((0, 0), (30, 90))), ("b", 75.0, ((0, 45), (-30, 180)))):
        sides[name] = tmp_path / f"{name}.csv"
        sides[name].write_text(
            "point,X,Y,Z,B,C\n"
            + "".join(f"{name}{i},{x},10,50,{b},{c}\n" for i, (b, c) in enumerate(rows)),
            encoding="utf-8",
        )
    cli = _json(
        [
            *("task", "validate", sides["a"], sides["b"], "--machine", MACHINE.name),
            *("--params", params, "--reference-mm", "150", "--reference-u-um", "0.15"),
            *("--cte", "10.8e-6", "--cte-u", "0.15e-6", "--delta-t", "1.75"),
            *("--delta-t-u", "0.003", "--long-term", lt, "--tip-diameter", "0", "--json"),
        ]
    )
    library = validate_gauge_from_files(
        sides["a"],
        sides["b"],
        MACHINE.name,
        params,
        150.0,
        0.15e-3,
        expansion_coefficient=10.8e-6,
        expansion_coefficient_uncertainty=0.15e-6,
        temperature_difference=1.75,
        temperature_difference_uncertainty=0.003,
        long_term=lt,
        tip_diameter=0.0,
    )
    return cli, library.to_dict()


def case_validate_pooling(tmp_path):
    from mtmetrology.omm.validation_request import pooling_from_files

    params = _params(tmp_path / "params.json")
    sets = []
    for i, (b, c) in enumerate(((0, 0), (20, 90), (-20, 200))):
        sets.append(tmp_path / f"set{i}.csv")
        sets[-1].write_text(
            "point,X,Y,Z,B,C\n"
            + "".join(
                f"p{j},{10 * np.cos(t):.6f},{10 * np.sin(t):.6f},{50 + 3 * np.sin(2 * t):.6f},"
                f"{b},{c}\n"
                for j, t in enumerate(np.linspace(0, 6, 7))
            ),
            encoding="utf-8",
        )
    cli = _json(
        [
            *("task", "validate-pooling", *sets, "--machine", MACHINE.name, "--params", params),
            *("--diameter-mm", "20", "--diameter-u-um", "0.25", "--sphericity-um", "0.4"),
            *("--sphericity-u-um", "0.05", "--cte", "11.5e-6", "--delta-t", "0.5"),
            *("--tip-diameter", "0", "--draws", "4", "--points-per-draw", "6", "--seed", "3"),
            "--json",
        ]
    )
    library = pooling_from_files(
        sets,
        MACHINE.name,
        params,
        20.0,
        0.25e-3,
        sphericity=0.4e-3,
        sphericity_uncertainty=0.05e-3,
        expansion_coefficient=11.5e-6,
        temperature_difference=0.5,
        tip_diameter=0.0,
        draws=4,
        points_per_draw=6,
        seed=3,
    )
    return cli, library.to_dict()


def case_verify_length(tmp_path):
    from mtmetrology.samba import read_length_readings, verify_length

    gauge = tmp_path / "gauge.csv"
    result = runner.invoke(
        app,
        [
            *("length", "simulate", "--machine", MACHINE.name, "--end-a", "-100,-100,40"),
            *("--end-b", "100,100,40", "--pairs", "5", "--noise-um", "0.5", "--seed", "8"),
            *("-o", str(gauge)),
        ],
    )
    assert result.exit_code == 0, result.output
    length = float(np.hypot(200.0, 200.0))
    cli = _json(
        [
            *("length", "verify", gauge, "--machine", MACHINE.name, "--length", repr(length)),
            *("--u-length", "0.0002", "--json"),
        ]
    )
    library = verify_length(
        MACHINE,
        None,
        read_length_readings(gauge, MACHINE),
        length,
        tip_radius=MACHINE.tip_radius,
        u_length=0.0002,
    )
    return cli, library.to_dict()


def case_uncertainty_run(tmp_path):
    from mtmetrology.uncertainty.evaluation import evaluate_model
    from mtmetrology.uncertainty.modelfile import load_model

    model = Path(__file__).resolve().parents[2] / "examples" / "gum-h1-end-gauge.yaml"
    options = ("--method", "both", "--trials", "20000", "--seed", "3", "--p", "0.99")
    cli = _json(["uncertainty", "run", model, *options, "--json"])
    library = evaluate_model(
        load_model(model), "both", trials=20000, seed=3, p=0.99, source=str(model)
    )
    return cli, library.to_dict()


def case_cmm_budget(tmp_path):
    import yaml

    from mtmetrology.cmm.budget import ballplate_budget_file

    spec = {
        "kind": "ballplate-budget",
        "length_mm": 532.0,
        "observed": {"value_mm": 532.01797, "s_um": 2.0, "n": 6},
        "verification_um": 1.0,
        "indication_resolution_um": 0.1,
        "probe_reproducibility_um": 0.5,
        "air": {"temperature_C": 20.6, "pressure_Pa": 101325.0, "humidity_percent": 51.0},
        "hygrometer_U_percent": 1.1,
        "humidity_resolution_percent": 1.0,
        "barometer_U_Pa": 20.0,
        "pressure_resolution_Pa": 1.0,
        "air_thermometer_U_K": 0.02,
        "air_thermometer_resolution_K": 0.01,
        "misalignment_um": 50.0,
        "part_temperature_C": 20.6,
        "part_thermometer_U_K": 0.02,
        "temperature_spread_K": 0.5,
        "cte_per_K": 11.5e-6,
        "cte_halfwidth_per_K": 1.0e-6,
    }
    path = tmp_path / "budget.yaml"
    path.write_text(yaml.safe_dump(spec), encoding="utf-8")
    cli = _json(["cmm", "budget", path, "-o", tmp_path / "out.json", "--json"])
    return cli, ballplate_budget_file(path).to_dict()


def case_machine_identifiability(tmp_path):
    from mtmetrology.samba.identifiability import setup_identifiability

    examples = Path(__file__).resolve().parents[2] / "examples" / "samba"
    artefact, poses = examples / "artefact.yaml", tmp_path / "programme.csv"
    _json(  # the example's probing programme as ball-centre indications (ball,X,Y,Z,B,C,S)
        [
            *("samba", "simulate", "--machine", "five-axis-wcbxfzyst", "--model", "13"),
            *("--artefact", artefact, "--truth", examples / "truth.json"),
            *("--balls", examples / "balls.yaml", "--poses", examples / "poses.csv"),
            *("--seed", "1", "-o", poses),
        ],
        json_output=False,
    )
    cli = _json(
        [
            *("machine", "identifiability", "five-axis-wcbxfzyst", poses),
            *("--artefact", artefact, "--sigma-um", "0.7", "--json"),
        ]
    )
    library = setup_identifiability("five-axis-wcbxfzyst", poses, artefact=artefact, sigma_um=0.7)
    return cli, library.to_dict()


def case_export_verify(tmp_path):
    """``mtm export siemens --verify-program``: check.json is the library's export, and the
    template holds the library's prediction at the check points."""
    from mtmetrology.export.verification import TEMPLATE, export_with_verification

    params = _params(tmp_path / "params.json")
    out = tmp_path / "out"
    cli = _json(
        [
            *("export", "siemens", params, "--machine", MACHINE.name, "--pitch", "20"),
            *("--verify-program", "--verify-positions", "3", "-o", out, "--json"),
        ]
    )
    library, files = export_with_verification(
        MACHINE, ParameterSet.load(params, MACHINE), "siemens", verify_positions=3, pitch=20
    )
    # the same rows; the first comment line carries the time of writing
    written = (out / TEMPLATE).read_text().splitlines()
    assert written[1:] == files[TEMPLATE].splitlines()[1:]
    return cli, library.to_dict()


def case_export_check(tmp_path):
    """``mtm export check`` on a filled template is :func:`compare_readings`."""
    from mtmetrology.export.verification_check import compare_readings

    path = tmp_path / "readings.csv"
    path.write_text(
        "point,axis,rx_um,ry_um,rz_um,Ux_um,Uy_um,Uz_um,ex_um,ey_um,ez_um,mx_um,my_um,mz_um\n"
        "X01+,X,0.5,0,0,1.0,,,-20.0,0,0,0.9,,\n"
        "X02+,X,-0.4,0,0,1.0,,,15.0,0,0,-0.1,,\n"
        "Y01-,Y,0.2,0.3,0,1.0,1.0,,4.0,-12.0,0,,0.1,\n",
        encoding="utf-8",
    )
    cli = _json(["export", "check", path, "--u-reading", "0.3", "--json"])
    return cli, compare_readings(path, 0.3).to_dict()


CASES = {
    "export siemens --verify-program": case_export_verify,
    "export check": case_export_check,
    "cmm budget": case_cmm_budget,
    "machine identifiability": case_machine_identifiability,
    "uncertainty run": case_uncertainty_run,
    "budget volumetric-map": case_volumetric_map,
    "cmm compare": case_cmm_compare,
    "samba compare-plans": case_design_compare,
    "task validate": case_validate_task,
    "task validate-pooling": case_validate_pooling,
    "length verify": case_verify_length,
    "cmm calibrate": case_ballplate,
    "repeatability fit": case_repeatability_fit,
    "length simulate": case_simulate_length,
    "tracker calibrate": case_tracker,
    "multilateration calibrate": case_multilateration,
    "repeatability hysteresis": case_hysteresis,
    "budget iso15530-3": case_budget,
    "task uncertainty": case_task,
    "fit": case_fit,
    "predict": case_predict,
}


@pytest.mark.parametrize("command", sorted(CASES))
def test_command_output_is_the_library_result(command, tmp_path):
    """... and states k beside every U with U = k u (issue 31, the coverage policy)."""
    cli, library = CASES[command](tmp_path)
    assert cli == _plain(library)
    assert unstated_coverage(cli) == []


def test_parity_detects_a_field_the_command_would_add(tmp_path):
    """The comparison is field for field: one extra field makes the documents differ."""
    cli, library = case_fit(tmp_path)
    assert cli != {**_plain(library), "added_by_the_command": 1}


def test_calibrate_unexplained_output_is_the_library_result(tmp_path):
    """``mtm samba unexplained`` equals :func:`mtmetrology.samba.unexplained_from_campaigns`
    on three simulated campaigns of the example SAMBA test."""
    from pathlib import Path

    from mtmetrology.samba import load_artefact, read_records, unexplained_from_campaigns

    examples = Path(__file__).resolve().parents[2] / "examples" / "samba"
    common = ["--machine", "five-axis-wcbxfzyst", "--model", "13"]
    common += ["--artefact", examples / "artefact.yaml"]
    files = []
    for k in range(3):
        files.append(tmp_path / f"c{k}.csv")
        result = runner.invoke(
            app,
            [
                str(a)
                for a in [
                    *("samba", "simulate", *common, "--truth", examples / "truth.json"),
                    *("--balls", examples / "balls.yaml", "--poses", examples / "poses.csv"),
                    *("--seed", k, "-o", files[-1]),
                ]
            ],
        )
        assert result.exit_code == 0, result.output
    cli = _json(["samba", "unexplained", *files, *common, "--noise-um", "0.5", "--json"])
    m = Machine.load("five-axis-wcbxfzyst", "13")
    art = load_artefact(examples / "artefact.yaml")
    recs = [read_records(f, m, art) for f in files]
    library = unexplained_from_campaigns(m, recs, art, sigma=0.5e-3)
    assert cli == _plain(library.to_dict())
