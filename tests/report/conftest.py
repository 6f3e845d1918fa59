"""Fixtures of the report tests: input files for each command with ``--report``, and the
headless browser that checks the pages.

Without Chromium the browser tests skip with the reason; with ``MTM_REQUIRE_BROWSER=1``
(set by ``.ci/run``) a missing browser fails them instead. Screenshots and printed PDFs
go to ``$MTM_TEST_ARTIFACTS/browser`` or ``test-artifacts/browser/`` (git-ignored).
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import numpy as np
import pytest
import yaml
from chromium import Chromium, find_chromium

from mtmetrology.cmm.files import BallPlate, PositionSet, ProbeSet, write_records
from mtmetrology.cmm.simulate import simulate_ballplate
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.samba import SambaSetup, probing_sequence

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples"

ARTEFACT = """kind: samba-artefact
balls:
  - {id: "1", diameter_mm: 12.7}
  - {id: "2", diameter_mm: 12.7}
  - {id: SB1, diameter_mm: 12.7}
  - {id: SB2, diameter_mm: 12.7}
scale_bar: {ends: [SB1, SB2], length_mm: 305.2105, u_mm: 0.0012}
"""

#: E_X0C of the parameter set: a pure offset of the C axis line, −104.6 µm (mm here).
E_X0C_MM = -0.1046


@pytest.fixture(scope="session")
def command_inputs(tmp_path_factory) -> dict[str, Path]:
    """Files for one run of each command that writes a report.

    ``model``: GUM H.1 end gauge; ``sphere``: 20 points on a 12.7 mm sphere; ``poses``
    and ``artefact``: a two-ball SAMBA strategy with spindle indexing (30 B/C pairs);
    ``params``: a parameter set with only E_X0C; ``records``: two probing records.
    """
    d = tmp_path_factory.mktemp("command-inputs")
    m = Machine.load("five-axis-wcbxfzyst")
    rng = np.random.default_rng(7)
    u = rng.standard_normal((20, 3))
    points = 12.7 * u / np.linalg.norm(u, axis=1, keepdims=True)
    sphere = d / "sphere.csv"
    sphere.write_text("x,y,z\n" + "\n".join(",".join(f"{v:.9f}" for v in p) for p in points) + "\n")
    setup = SambaSetup(
        balls={"1": (-80, -40, 100), "2": (80, 120, 150)},
        scale_bar={"SB1": (-152.60525, 0, 30), "SB2": (152.60525, 0, 30)},
    )
    # B within ±60°: at ±90° the scale-bar ends would need Z below its travel (-110 mm)
    pairs = [(b, c) for b in (-60, -30, 0, 30, 60) for c in range(0, 360, 60)]
    ids, q = probing_sequence(m, setup, pairs)
    rows = zip(ids, m.readings_to_customary(q), strict=True)
    poses = d / "poses.csv"
    poses.write_text(
        "ball,X,Y,Z,B,C,S\n"
        + "\n".join(f"{i}," + ",".join(f"{v:.6f}" for v in r) for i, r in rows)
        + "\n"
    )
    (d / "artefact.yaml").write_text(ARTEFACT)
    values = np.zeros(m.n_params)
    values[m.parameter_names.index("E_X0C")] = E_X0C_MM
    ParameterSet(m.parameter_names, values, m.parameter_units, machine=m.name).save(
        d / "params.json"
    )
    records = d / "records.csv"
    records.write_text("id,X,Y,Z,B,C\np1,-138.565,94.656,196.232,-42,-293\np2,10,20,30,15,40\n")
    (d / "ball-grid.yaml").write_text(BALL_GRID)
    return {
        **_ballplate_inputs(d),
        **_samba_inputs(d),
        "model": EXAMPLES / "gum-h1-end-gauge.yaml",
        "sphere": sphere,
        "poses": poses,
        "n_poses": len(ids),
        "artefact": d / "artefact.yaml",
        "params": d / "params.json",
        "records": records,
        "ball_grid": d / "ball-grid.yaml",
    }


SAMBA_EXAMPLES = EXAMPLES / "samba"
SAMBA_MACHINE = "five-axis-wcbxfzyst"
#: The gauge length of the SAMBA length check: the diagonal of a 200 mm square.
GAUGE_LENGTH_MM = float(np.hypot(200.0, 200.0))


def _samba_inputs(d: Path) -> dict:
    """SAMBA records (13-parameter model, 0.5 µm noise) and gauge-length readings of the
    example machine, simulated with the CLI from the files of examples/samba."""
    from typer.testing import CliRunner

    from mtmetrology.cli import app

    runner = CliRunner()
    common = ["--machine", SAMBA_MACHINE, "--truth", str(SAMBA_EXAMPLES / "truth.json")]
    samba = [*common, "--model", "13", "--artefact", str(SAMBA_EXAMPLES / "artefact.yaml"),
             "--balls", str(SAMBA_EXAMPLES / "balls.yaml"),
             "--poses", str(SAMBA_EXAMPLES / "poses.csv"), "--noise-um", "0.5", "--seed", "1",
             "-o", str(d / "samba.csv")]  # fmt: skip
    gauge = [*common, "--end-a", "-100,-100,40", "--end-b", "100,100,40", "--pairs", "8",
             "--seed", "5", "-o", str(d / "gauge.csv")]  # fmt: skip
    for args in (["samba", "simulate", *samba], ["length", "simulate", *gauge]):
        result = runner.invoke(app, args)
        assert result.exit_code == 0, result.output
    return {
        "samba_records": d / "samba.csv",
        "samba_artefact": SAMBA_EXAMPLES / "artefact.yaml",
        "gauge": d / "gauge.csv",
        "gauge_pairs": 8,
    }


#: Candidate balls of the design report: 3 x 2 positions, two stems.
BALL_GRID = """kind: samba-ball-grid
x_mm: [-80, 0, 80]
y_mm: [-40, 40]
stems_mm: [75, 150]
"""


#: A small ball-plate campaign: 3 x 3 plate, four positions (horizontal, two vertical,
#: tilted) probed with three styli; the errors of the seed model (µm, µrad).
PLATE_POSITIONS = {
    "H": ([330, 230, 150], [0, 0, 0]),
    "VX": ([330, 500, 10], [90, 0, 0]),
    "VY": ([600, 230, 10], [90, 0, 90]),
    "T": ([330, 230, 120], [30, 0, 0]),
}
STYLI = {"P0": [0, 0, -150], "PX1": [50, 0, -150], "PY1": [0, 50, -150]}
CMM_ERRORS = {"E_XX1": 6.0, "E_YY1": -4.0, "E_ZZ1": 3.0, "E_CX1": 8.0, "E_C0X": 10.0}
BUDGET = {
    "kind": "ballplate-budget", "length_mm": 532.0,
    "observed": {"value_mm": 532.01797, "s_um": 2.0, "n": 6},
    "verification_um": 1.0, "indication_resolution_um": 0.1, "probe_reproducibility_um": 0.5,
    "air": {"temperature_C": 20.6, "pressure_Pa": 101325.0, "humidity_percent": 51.0},
    "hygrometer_U_percent": 1.1, "humidity_resolution_percent": 1.0, "barometer_U_Pa": 20.0,
    "pressure_resolution_Pa": 1.0, "air_thermometer_U_K": 0.02,
    "air_thermometer_resolution_K": 0.01, "misalignment_um": 50.0, "part_temperature_C": 20.6,
    "part_thermometer_U_K": 0.02, "temperature_spread_K": 0.5, "cte_per_K": 11.5e-6,
    "cte_halfwidth_per_K": 1.0e-6,
}  # fmt: skip


def _ballplate_inputs(d: Path) -> dict:
    """Plate, probe set, simulated records of a virtual bridge CMM, and a budget file."""
    balls = [{"id": f"{3 * j + i:02d}", "x_mm": 266.0 * i, "y_mm": 266.0 * j, "z_mm": 0.0}
             for j in range(3) for i in range(3)]  # fmt: skip
    plate = {"kind": "ball-plate", "balls": balls, "u_mm": 0.0005}
    probes = {"kind": "probe-set", "probes": [{"id": k, "offset_mm": v} for k, v in STYLI.items()]}
    for name, doc in (("plate", plate), ("probes", probes), ("budget", BUDGET)):
        (d / f"{name}.yaml").write_text(yaml.safe_dump(doc, allow_unicode=True), encoding="utf-8")
    m = Machine.load("cmm-moving-bridge")
    units = {"E_XX1": "µm", "E_YY1": "µm", "E_ZZ1": "µm", "E_CX1": "µrad", "E_C0X": "µrad"}
    truth = {"kind": "parameter-set", "version": 1, "machine": m.name,
             "parameters": [{"name": n, "value": v, "unit": units[n]}
                            for n, v in CMM_ERRORS.items()]}  # fmt: skip
    pset = ParameterSet.from_document(truth, m)
    machine = pset.machine_for(m)
    theta = pset.vector_for(machine)
    positions = PositionSet(
        kind="ballplate-positions",
        positions=[{"id": k, "origin_mm": o, "rotation_deg": r, "probes": list(STYLI)}
                   for k, (o, r) in PLATE_POSITIONS.items()],
    )  # fmt: skip
    campaign = simulate_ballplate(
        machine, theta, BallPlate.model_validate(plate), positions,
        ProbeSet.model_validate(probes), sigma=0.0005, seed=3,
    )  # fmt: skip
    write_records(d / "ballplate.csv", campaign.records)
    return {
        "plate": d / "plate.yaml",
        "probes": d / "probes.yaml",
        "ballplate": d / "ballplate.csv",
        "budget": d / "budget.yaml",
        "n_plate_positions": len(PLATE_POSITIONS),
    }


@pytest.fixture(scope="session")
def report_commands(command_inputs):
    """``commands(out)``: one ``mtm`` argument list per command with ``--report`` into out."""
    return lambda out: _report_commands(command_inputs, out)


def _report_commands(inputs: dict, out: Path) -> dict[str, list[str]]:
    CMM = ["--machine", "cmm-moving-bridge", "--plate", str(inputs["plate"]),
           "--probes", str(inputs["probes"])]  # fmt: skip
    return {
        "uncertainty": ["uncertainty", "run", str(inputs["model"]), "--method", "both",
                        "--trials", "20000", "--seed", "4",
                        "--report", str(out / "uncertainty.html")],
        "fit": ["fit", "sphere", str(inputs["sphere"]), "--report", str(out / "fit.html")],
        "identifiability": ["machine", "identifiability", "five-axis-wcbxfzyst",
                            str(inputs["poses"]), "--artefact", str(inputs["artefact"]),
                            "--report", str(out / "identifiability.html")],
        "predict": ["predict", "--machine", "five-axis-wcbxfzyst", "--params",
                    str(inputs["params"]), str(inputs["records"]), "-o", str(out / "xyz.csv"),
                    "--report", str(out / "predict.html")],
        "ballplate": ["cmm", "calibrate", str(inputs["ballplate"]), *CMM,
                      "--model", "auto", "--candidates", "seed,full-1",
                      "-o", str(out / "ballplate.json"), "--report", str(out / "ballplate.html")],
        "ballplate-budget": ["cmm", "budget", str(inputs["budget"]),
                             "-o", str(out / "budget.json"),
                             "--report", str(out / "ballplate-budget.html")],
        # before samba-verify-length, which reads its RESULT.json
        "samba-calibrate": ["samba", "calibrate", str(inputs["samba_records"]),
                            "--machine", SAMBA_MACHINE, "--artefact", str(inputs["samba_artefact"]),
                            "--estimate-tool", "--uncertainty", "both", "--trials", "1000",
                            "--seed", "3", "-o", str(out / "samba.json"),
                            "--report", str(out / "samba-calibrate.html")],
        "samba-verify-length": ["length", "verify", str(inputs["gauge"]),
                                "--machine", SAMBA_MACHINE, "--params", str(out / "samba.json"),
                                "--length", f"{GAUGE_LENGTH_MM:.9f}", "-o", str(out / "gauge.json"),
                                "--report", str(out / "samba-verify-length.html")],
        "design": ["samba", "plan", "--machine", "five-axis-wcbxfzyst", "--model", "13",
                   "--balls-from", str(inputs["ball_grid"]), "--n-balls", "2", "--k", "3",
                   "--criterion", "D", "--starts", "2", "--seed", "5",
                   "--b-grid", "-90:90:15", "--c-grid", "0:330:30",
                   "-o", str(out / "programme.csv"), "--report", str(out / "design.html")],
        "gp-fit": ["gp", "fit", str(inputs["ballplate"]), *CMM, "-o", str(out / "gp.json"),
                   "--report", str(out / "gp-fit.html")],
    }  # fmt: skip


@pytest.fixture(scope="session")
def command_reports(report_commands, tmp_path_factory):
    """Every command run once with --report: ``{name: (result, report path)}``.

    Shared by the structural checks and the browser checks, so each command (the ball-plate
    report draws eight figures) runs once per session.
    """
    from typer.testing import CliRunner

    from mtmetrology.cli import app

    out = tmp_path_factory.mktemp("reports")
    runner = CliRunner()
    return {
        name: (runner.invoke(app, args), out / f"{name}.html")
        for name, args in report_commands(out).items()
    }


@pytest.fixture(scope="session")
def browser():
    executable = find_chromium()
    missing = None
    if executable is None:
        missing = "Chromium not found (Debian: apt-get install chromium; or set MTM_CHROMIUM)"
    elif importlib.util.find_spec("websocket") is None:
        missing = "websocket-client not installed (pip install -e '.[test]')"
    if missing:
        if os.environ.get("MTM_REQUIRE_BROWSER") == "1":
            pytest.fail(f"MTM_REQUIRE_BROWSER=1 but {missing}")
        pytest.skip(f"browser checks skipped: {missing}")
    chromium = Chromium(executable)
    yield chromium
    chromium.close()


@pytest.fixture(scope="session")
def artefacts() -> Path:
    path = Path(os.environ.get("MTM_TEST_ARTIFACTS", ROOT / "test-artifacts")) / "browser"
    path.mkdir(parents=True, exist_ok=True)
    return path
