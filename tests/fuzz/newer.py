"""The outside corpus extended to the commands added since the first hardening (issue 32).

Tracker, multilateration, budgets, export, cmm, validate, verify, samba
unexplained/long-term, task: one valid input of each (:func:`valid_files`, made once per
process by the simulate commands and the library), and cases that break one thing in the
classes of the issue -- a position outside the travel, a temperature out of range, a
length that is not positive, a negative uncertainty, a scale 10³ off, a repeated file, an
unknown key, NaN, an empty file, a huge size.  Every case must end ``clear``
(:func:`tests.fuzz.corpus.run`: exit 2, one line naming the file or option, no
traceback, nothing written); the ``accepted`` ones (the valid inputs themselves) exit 0.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np
import yaml
from tests.fuzz.catalogue import Case, _csv_cell, _csv_lines, _json, _replace, _set
from typer.testing import CliRunner

from mtmetrology.cli import app

M3 = "three-axis-xfyz"
M5 = "five-axis-wcbxfzyst"
CMM = "cmm-moving-bridge"
MESH = "800:1200:100,100:500:100,200:400:100"
SAMBA = Path(__file__).resolve().parents[2] / "examples" / "samba"

#: Placeholder -> file name of every input.
NAMES = {
    "tools": "tools.yaml",
    "meas": "meas.csv",
    "pose": "pose.yaml",
    "conditions": "conditions.yaml",
    "stations": "stations.yaml",
    "lengths": "lengths.csv",
    "map": "map.json",
    "runs": "runs.csv",
    "ring": "ring.csv",
    "plate": "plate.yaml",
    "probes": "probes.yaml",
    "records": "records.csv",
    "qualification": "qualification.csv",
    "samba": "samba.csv",
    "artefact": "artefact.yaml",
    "params5": "params5.json",
    "lt5": "lt5.json",
    "task": "task.csv",
    "side_a": "a.csv",
    "side_b": "b.csv",
    "set0": "set0.csv",
    "set1": "set1.csv",
    "gauge": "gauge.csv",
    "dballs": "balls.yaml",
    "pairs": "pairs.csv",
}


def _mtm(*args) -> None:
    res = CliRunner().invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, res.output


def _params5(path: Path, seed: int) -> None:
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.parameter_set import ParameterSet

    m = Machine.load(M5)
    rng = np.random.default_rng(seed)
    a = m.parameter_scales[:, None] * rng.normal(size=(m.n_params, m.n_params))
    ParameterSet(
        m.parameter_names,
        rng.normal(size=m.n_params) * m.parameter_scales * 3,
        m.parameter_units,
        covariance=a @ a.T,
        machine=m.name,
    ).save(path)


def _ballplate(d: Path) -> None:
    from mtmetrology.cmm.files import BallPlateRecords, write_records
    from mtmetrology.kinematics.machine import Machine

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
    for name, doc in docs.items():
        (d / f"{name}.yaml").write_text(yaml.safe_dump(doc), encoding="utf-8")
    _mtm("cmm", "simulate", "--machine", CMM, "--plate", d / "plate.yaml", "--probes",
         d / "probes.yaml", "--positions", d / "positions.yaml", "--seed", 3,
         "-o", d / "records.csv")  # fmt: skip
    machine = Machine.load(CMM)
    ids = list(probes) * 2
    tools = np.array([probes[k] for k in ids], dtype=float)
    sphere = np.array([600.0, 500.0, 300.0])
    q = machine.inverse(np.tile(sphere, (len(ids), 1)), sphere - tools, tool=tools)
    q = q + 0.0005 * np.random.default_rng(8).standard_normal(q.shape)
    rec = BallPlateRecords(("Q",) * len(ids), ("S",) * len(ids), tuple(ids), q,
                           np.arange(len(ids)) + 2)  # fmt: skip
    write_records(d / "qualification.csv", rec)


def _make(d: Path) -> None:
    """Write every valid input into ``d``."""
    (d / "tools.yaml").write_text(
        "kind: tracker-tools\nversion: 1\n"
        "tools_mm: [[0, 0, -100], [100, 0, -100], [0, 100, -100]]\n"
    )
    _mtm("tracker", "simulate", "--machine", M3, "--mesh", MESH, "--tools", d / "tools.yaml",
         "--seed", 4, "-o", d / "meas.csv")  # fmt: skip
    (d / "pose.yaml").write_text(
        "kind: tracker-pose\nversion: 1\nD_mm: -1200\nL_mm: 300\nH_mm: 700\n"
        "alpha_deg: 0\nbeta_deg: 0\ndelta_deg: 0\n"
    )
    (d / "conditions.yaml").write_text(
        "kind: tracker-conditions\nversion: 1\n"
        "sensor_temperatures_C: [[20.1, 20.3], [20.0, 20.2], [19.9, 20.1]]\nu_sensor_K: 0.05\n"
        "cte_per_K: [11.5e-6, 11.5e-6, 11.5e-6]\n"
    )
    (d / "stations.yaml").write_text(
        "kind: multilateration-stations\nversion: 1\nstations:\n"
        "  - {name: S1, position_mm: [750, 50, 30], dead_path_mm: 100}\n"
        "  - {name: S2, position_mm: [1250, 60, 40], dead_path_mm: 200}\n"
        "  - {name: S3, position_mm: [760, 560, 20], dead_path_mm: 300}\n"
        "  - {name: S4, position_mm: [1240, 540, 50], dead_path_mm: 400}\n"
    )
    _mtm("multilateration", "simulate", "--machine", M3, "--stations", d / "stations.yaml",
         "--grid", "4,4,4", "--seed", 1, "-o", d / "lengths.csv")  # fmt: skip
    _mtm("multilateration", "calibrate", d / "lengths.csv", "--machine", M3, "-o", d / "map.json")
    a = 0.001 * math.sqrt(19.0 / 20.0)
    runs = 10.002 + a * np.tile([-1.0, 1.0], 10)
    (d / "runs.csv").write_text("value\n" + "".join(f"{v:.7f}\n" for v in runs))
    t = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    rng = np.random.default_rng(0)
    rows = ["x,y,z,cycle"]
    for c in range(3):
        ring = np.c_[1000 + 54 * np.cos(t), 300 + 54 * np.sin(t), np.full(12, 150.0)]
        ring += rng.normal(0, 1e-3, ring.shape)
        rows += [f"{x:.6f},{y:.6f},{z:.6f},{c}" for x, y, z in ring]
    (d / "ring.csv").write_text("\n".join(rows) + "\n")
    _ballplate(d)
    (d / "artefact.yaml").write_text((SAMBA / "artefact.yaml").read_text())
    _mtm("samba", "simulate", "--machine", M5, "--model", "13", "--truth", SAMBA / "truth.json",
         "--artefact", SAMBA / "artefact.yaml", "--balls", SAMBA / "balls.yaml", "--poses",
         SAMBA / "poses.csv", "--seed", 1, "-o", d / "samba.csv")  # fmt: skip
    _params5(d / "params5.json", 1)
    _params5(d / "lt5.json", 2)
    (d / "task.csv").write_text(
        "point,X,Y,Z,B,C,end\np1,-138.5650,94.6560,196.2320,-42,-293,1\n"
        "p2,-61.2880,48.3440,246.8170,-64,-124,2\n"
    )
    for name, x, sides in (("a", -75.0, ((0, 0), (30, 90))), ("b", 75.0, ((0, 45), (-30, 180)))):
        (d / f"{name}.csv").write_text(
            "point,X,Y,Z,B,C\n"
            + "".join(f"{name}{i},{x},10,50,{b},{c}\n" for i, (b, c) in enumerate(sides))
        )
    for i, (b, c) in enumerate(((0, 0), (20, 90))):
        (d / f"set{i}.csv").write_text(
            "point,X,Y,Z,B,C\n"
            + "".join(
                f"p{j},{10 * np.cos(s):.6f},{10 * np.sin(s):.6f},{50 + 3 * np.sin(2 * s):.6f},"
                f"{b},{c}\n"
                for j, s in enumerate(np.linspace(0, 6, 7))
            )
        )
    (d / "balls.yaml").write_text(
        'kind: samba-balls\nballs:\n  - {id: "1", centre_mm: [-80, -40, 100]}\n'
    )
    (d / "pairs.csv").write_text(
        "B,C\n" + "".join(f"{b},{c}\n" for b in range(-90, 91, 30) for c in range(0, 360, 45))
    )
    _mtm("length", "simulate", "--machine", M5, "--end-a", "-100,-100,40", "--end-b",
         "100,100,40", "--pairs", 5, "--noise-um", 0.5, "--seed", 8,
         "-o", d / "gauge.csv")  # fmt: skip


_BASE: dict[str, str] | None = None


def valid_files() -> dict[str, str]:
    """Placeholder -> text of every valid input, made once per process."""
    global _BASE
    if _BASE is None:
        with tempfile.TemporaryDirectory() as tmp:
            d = Path(tmp)
            _make(d)
            _BASE = {k: (d / name).read_text(encoding="utf-8") for k, name in NAMES.items()}
    return _BASE


def materialise(directory: Path, files: dict[str, str | bytes]) -> dict[str, str]:
    """Write the files; placeholder -> path, plus ``out`` (a JSON), ``csv``, ``dir``."""
    paths = {}
    for key, content in files.items():
        p = directory / NAMES[key]
        if isinstance(content, bytes):
            p.write_bytes(content)
        else:
            p.write_text(content, encoding="utf-8", newline="")
        paths[key] = str(p)
    paths |= {"out": str(directory / "out.json"), "csv": str(directory / "out.csv")}
    paths["dir"] = str(directory)
    return paths


# ---- the commands, on the valid inputs ----
TRACKER = ("tracker", "calibrate", "{meas}", "--machine", M3, "-o", "{out}")
TRACKER_POSE = (*TRACKER, "--pose", "{pose}")
TRACKER_CONDITIONS = (*TRACKER, "--conditions", "{conditions}")
SIM_TRACKER = ("tracker", "simulate", "--machine", M3, "--mesh", MESH, "--tools", "{tools}",
               "-o", "{csv}")  # fmt: skip
VERIFY_TRACKER = ("tracker", "verify", "--machine", M3, "--trials", "20", "--seed", "1",
                  "-o", "{out}")  # fmt: skip
PLACEMENT = ("tracker", "plan", "--machine", M3, "--trials", "200", "--seed", "1",
             "-o", "{out}")  # fmt: skip
SIM_MULTI = ("multilateration", "simulate", "--machine", M3, "--stations", "{stations}",
             "--grid", "3,3,3", "-o", "{csv}")  # fmt: skip
CAL_MULTI = ("multilateration", "calibrate", "{lengths}", "--machine", M3, "-o", "{out}")
ISO = ("budget", "iso15530-3", "{runs}", "--calibrated", "10", "--u-cal", "0.5", "-o", "{out}")
MAP = ("budget", "volumetric-map", "{ring}", "--machine", M3, "--params", "{map}",
       "--feature", "circle", "-o", "{out}")  # fmt: skip
FANUC = ("export", "fanuc", "{map}", "--machine", M3, "--points", "5", "-o", "{dir}/exp")
ISG = ("export", "isg", "{map}", "--machine", M3, "--points", "5", "-o", "{dir}/exp")
BALLPLATE = ("{records}", "--machine", CMM, "--plate", "{plate}", "--probes", "{probes}")
CMM_CAL = ("cmm", "calibrate", *BALLPLATE, "--qualification", "{qualification}",
           "--length", "00,08,752.362,0.2", "-o", "{out}")  # fmt: skip
CMM_COMPARE = ("cmm", "compare", *BALLPLATE, "--held-out", "VY", "--model", "seed",
               "-o", "{out}")  # fmt: skip
SAMBA_CAL = ("samba", "calibrate", "{samba}", "--machine", M5, "--model", "13",
             "--artefact", "{artefact}", "-o", "{out}")  # fmt: skip
UNEXPLAINED = ("samba", "unexplained", "{samba}", "{samba}", "--machine", M5, "--model",
               "13", "--artefact", "{artefact}", "-o", "{out}")  # fmt: skip
LONG_TERM = ("samba", "long-term", "{params5}", "{lt5}", "-o", "{out}")
TASK = ("task", "uncertainty", "{task}", "--machine", M5, "--params", "{params5}",
        "--feature", "length", "--long-term", "{lt5}", "-o", "{out}")  # fmt: skip
VALIDATE_TASK = ("task", "validate", "{side_a}", "{side_b}", "--machine", M5, "--params",
                 "{params5}", "--reference-mm", "150", "--reference-u-um", "0.15",
                 "--long-term", "{lt5}", "-o", "{out}")  # fmt: skip
POOLING = ("task", "validate-pooling", "{set0}", "{set1}", "--machine", M5, "--params", "{params5}",
           "--diameter-mm", "20", "--diameter-u-um", "0.25", "--draws", "3",
           "--points-per-draw", "5", "--seed", "3", "-o", "{out}")  # fmt: skip
VERIFY_LENGTH = ("length", "verify", "{gauge}", "--machine", M5, "--length",
                 repr(float(np.hypot(200.0, 200.0))), "-o", "{out}")  # fmt: skip

DESIGN_COMPARE = ("samba", "compare-plans", "--machine", M5, "--model", "13", "--balls", "{dballs}",
                  "--indexations", "{pairs}", "--n-balls", "1", "--k", "3", "--starts", "1",
                  "--criterion", "D", "--seed", "5", "-o", "{out}")  # fmt: skip


def _with(args: tuple, option: str, value: str) -> tuple:
    """``args`` with ``option``'s value replaced (or the option added)."""
    out = list(args)
    if option in out:
        out[out.index(option) + 1] = value
        return tuple(out)
    return (*out, option, value)


def _kelvin(key: str, columns: tuple[int, ...]):
    def change(lines):
        out = [lines[0]]
        for line in lines[1:]:
            cells = line.split(",")
            if line and len(cells) > max(columns):
                for c in columns:
                    cells[c] = f"{float(cells[c]) + 273.15:.6f}"
            out.append(",".join(cells))
        return out

    return _csv_lines(key, change)


def _scaled(key: str, columns: tuple[int, ...], factor: float):
    def change(lines):
        out = [lines[0]]
        for line in lines[1:]:
            cells = line.split(",")
            if line and len(cells) > max(columns):
                for c in columns:
                    cells[c] = repr(float(cells[c]) * factor)
            out.append(",".join(cells))
        return out

    return _csv_lines(key, change)


def _header_only(key: str):
    return lambda f: {**f, key: f[key].split("\n", 1)[0] + "\n"}


def _param_u(value: float):
    def change(doc):
        doc["parameters"][0]["u"] = value

    return _json("params5", change)


# (id, mutation, command, placeholder or literal the one line must name)
REFUSED = [
    # tracker calibrate: MEASUREMENTS.csv (point,X,Y,Z,tool_x..z,range,azimuth,elevation,T_X..Z)
    ("tracker-outside-travel", _csv_cell("meas", 6, 1, "5000"), TRACKER, "meas"),
    ("tracker-kelvin", _kelvin("meas", (10, 11, 12)), TRACKER, "meas"),
    ("tracker-temperature-2000", _csv_cell("meas", 5, 10, "2000"), TRACKER, "meas"),
    ("tracker-azimuth-radians", _scaled("meas", (8,), math.pi / 180), TRACKER, "meas"),
    ("tracker-range-metres", _scaled("meas", (7,), 1e-3), TRACKER, "meas"),
    ("tracker-nan", _csv_cell("meas", 3, 9, "nan"), TRACKER, "meas"),
    ("tracker-header-only", _header_only("meas"), TRACKER, "meas"),
    ("tracker-empty", _set("meas", ""), TRACKER, "meas"),
    (
        "tracker-pose-unknown-key",
        _replace("pose", "delta_deg: 0", "delta_deg: 0\ngamma_deg: 3"),
        TRACKER_POSE,
        "pose",
    ),
    ("tracker-pose-nan", _replace("pose", "D_mm: -1200", "D_mm: .nan"), TRACKER_POSE, "pose"),
    (
        "tracker-conditions-unknown-key",
        _replace("conditions", "u_sensor_K", "u_sensors_K"),
        TRACKER_CONDITIONS,
        "conditions",
    ),
    (
        "tracker-conditions-2000",
        _replace("conditions", "[[20.1,", "[[2000,"),
        TRACKER_CONDITIONS,
        "conditions",
    ),
    (
        "tracker-conditions-cte-um-per-m",
        _replace("conditions", "[11.5e-6,", "[11.5,"),
        TRACKER_CONDITIONS,
        "conditions",
    ),
    (
        "tracker-tools-nan",
        _replace("tools", "[0, 0, -100]", "[0, .nan, -100]"),
        SIM_TRACKER,
        "tools",
    ),
    (
        "tracker-tools-empty",
        _replace(
            "tools", "tools_mm: [[0, 0, -100], [100, 0, -100], [0, 100, -100]]", "tools_mm: []"
        ),
        SIM_TRACKER,
        "tools",
    ),
    # multilateration
    (
        "stations-unknown-key",
        _replace("stations", "dead_path_mm: 100}", "dead_path_mm: 100, colour: red}"),
        SIM_MULTI,
        "stations",
    ),
    (
        "stations-negative-dead-path",
        _replace("stations", "dead_path_mm: 100}", "dead_path_mm: -100}"),
        SIM_MULTI,
        "stations",
    ),
    (
        "stations-nan",
        _replace("stations", "[750, 50, 30]", "[750, .nan, 30]"),
        SIM_MULTI,
        "stations",
    ),
    ("stations-empty", _set("stations", ""), SIM_MULTI, "stations"),
    ("lengths-nan", _csv_cell("lengths", 4, 7, "nan"), CAL_MULTI, "lengths"),
    ("lengths-header-only", _header_only("lengths"), CAL_MULTI, "lengths"),
    ("lengths-outside-travel", _csv_cell("lengths", 4, 1, "5000"), CAL_MULTI, "lengths"),
    # budget iso15530-3
    ("runs-19", _csv_lines("runs", lambda ls: [*ls[:20], ""]), ISO, "runs"),
    ("runs-2", _csv_lines("runs", lambda ls: [*ls[:3], ""]), ISO, "runs"),
    ("runs-nan", _csv_cell("runs", 4, 0, "nan"), ISO, "runs"),
    ("runs-header-only", _header_only("runs"), ISO, "runs"),
    ("runs-micrometres", _scaled("runs", (0,), 1e3), ISO, "runs"),
    # budget volumetric-map
    ("ring-micrometres", _scaled("ring", (0, 1, 2), 1e3), MAP, "ring"),
    ("ring-5-m-outside", _scaled("ring", (0,), 6.0), MAP, "ring"),
    ("map-trials-huge", lambda f: f, (*MAP, "--u-cal", "mc", "--trials", "1000000000"), "--trials"),
    ("ring-nan", _csv_cell("ring", 3, 1, "nan"), MAP, "ring"),
    ("ring-header-only", _header_only("ring"), MAP, "ring"),
    ("map-u-negative", _json("map", lambda d: d["parameters"][0].update(u=-1.0)), FANUC, "map"),
    ("map-empty", _set("map", ""), FANUC, "map"),
    # cmm
    (
        "plate-length-metres",
        lambda f: f,
        _with(CMM_CAL, "--length", "00,08,0.752362,0.2"),
        "--length",
    ),
    (
        "plate-length-negative",
        lambda f: f,
        _with(CMM_CAL, "--length", "00,08,-752.362,0.2"),
        "--length",
    ),
    ("cmm-gp-mean-word", lambda f: f, (*CMM_COMPARE, "--gp-mean", "foo"), "--gp-mean"),
    ("cmm-records-header-only", _header_only("records"), CMM_COMPARE, "records"),
    # samba scale bar, repeated campaigns and calibrations
    (
        "samba-scale-bar-mm-as-m",
        _replace("artefact", "length_mm: 305.569", "length_mm: 0.305569"),
        SAMBA_CAL,
        "scale_bar",
    ),
    (
        "samba-scale-bar-um",
        _replace("artefact", "length_mm: 305.569", "length_mm: 305569"),
        SAMBA_CAL,
        "scale_bar",
    ),
    ("unexplained-same-file-twice", lambda f: f, UNEXPLAINED, "samba"),
    (
        "long-term-same-file-twice",
        lambda f: f,
        ("samba", "long-term", "{params5}", "{params5}", "-o", "{out}"),
        "params5",
    ),
    ("long-term-copy", lambda f: {**f, "lt5": f["params5"]}, LONG_TERM, "lt5"),
    # task, validate, length verify
    ("task-params-u-negative", _param_u(-1.0), TASK, "params5"),
    (
        "task-params-u-nan",
        _replace("params5", '"value": ', '"value": NaN, "x": '),
        TASK,
        "params5",
    ),
    ("task-points-header-only", _header_only("task"), TASK, "task"),
    (
        "validate-reference-zero",
        lambda f: f,
        _with(VALIDATE_TASK, "--reference-mm", "0"),
        "--reference-mm",
    ),
    (
        "validate-reference-negative",
        lambda f: f,
        _with(VALIDATE_TASK, "--reference-mm", "-282"),
        "--reference-mm",
    ),
    (
        "validate-reference-metres",
        lambda f: f,
        _with(VALIDATE_TASK, "--reference-mm", "0.15"),
        "--reference-mm",
    ),
    ("validate-side-header-only", _header_only("side_a"), VALIDATE_TASK, "side_a"),
    (
        "pooling-diameter-zero",
        lambda f: f,
        _with(POOLING, "--diameter-mm", "0"),
        "--diameter-mm",
    ),
    (
        "pooling-diameter-negative",
        lambda f: f,
        _with(POOLING, "--diameter-mm", "-25"),
        "--diameter-mm",
    ),
    ("pooling-same-set-twice", lambda f: {**f, "set1": f["set0"]}, POOLING, "set1"),
    (
        "verify-length-temperature-300",
        lambda f: f,
        (*VERIFY_LENGTH, "--temperature-c", "-300"),
        "--temperature-c",
    ),
    (
        "verify-length-kelvin",
        lambda f: f,
        (*VERIFY_LENGTH, "--temperature-c", "293.15"),
        "--temperature-c",
    ),
    ("verify-length-metres", lambda f: f, _with(VERIFY_LENGTH, "--length", "0.2828"), "--length"),
    ("verify-length-zero", lambda f: f, _with(VERIFY_LENGTH, "--length", "0"), "--length"),
    ("verify-length-gauge-header-only", _header_only("gauge"), VERIFY_LENGTH, "gauge"),
    # huge sizes: refused before the work starts, saying how much
    (
        "design-compare-starts-huge",
        lambda f: f,
        _with(DESIGN_COMPARE, "--starts", "100000000"),
        "--starts",
    ),
    ("design-compare-indexations-header-only", _header_only("pairs"), DESIGN_COMPARE, "pairs"),
    (
        "design-compare-balls-nan",
        _replace("dballs", "[-80, -40, 100]", "[-80, .nan, 100]"),
        DESIGN_COMPARE,
        "dballs",
    ),
    (
        "design-compare-gauge-negative",
        lambda f: f,
        (*DESIGN_COMPARE, "--gauge-mm", "-100"),
        "--gauge-mm",
    ),
    (
        "verify-tracker-trials-huge",
        lambda f: f,
        _with(VERIFY_TRACKER, "--trials", "1000000000"),
        "--trials",
    ),
    (
        "placement-trials-huge",
        lambda f: f,
        _with(PLACEMENT, "--trials", "1000000000"),
        "--trials",
    ),
    (
        "multilateration-grid-huge",
        lambda f: f,
        _with(SIM_MULTI, "--grid", "1000,1000,1000"),
        "--grid",
    ),
    ("fanuc-pitch-tiny", lambda f: f, (*FANUC[:5], "--pitch", "0.01", *FANUC[7:]), "--pitch"),
    ("isg-pitch-tiny", lambda f: f, (*ISG[:5], "--pitch", "0.001", *ISG[7:]), "pitch"),
    # options that are numbers but not plausible ones
    ("fanuc-bound-negative", lambda f: f, (*FANUC, "--bound", "-1"), "--bound"),
    ("fanuc-bound-zero", lambda f: f, (*FANUC, "--bound", "0"), "--bound"),
    ("iso-calibrated-nan", lambda f: f, _with(ISO, "--calibrated", "nan"), "--calibrated"),
    ("iso-u-cal-negative", lambda f: f, _with(ISO, "--u-cal", "-1"), "--u-cal"),
]

#: The valid inputs of each command: exit 0 (the base of the refusals above is valid).
ACCEPTED = [
    ("tracker", TRACKER),
    ("tracker-pose", TRACKER_POSE),
    ("tracker-conditions", TRACKER_CONDITIONS),
    ("multilateration", CAL_MULTI),
    ("iso15530-3", ISO),
    ("volumetric-map", MAP),
    ("fanuc", FANUC),
    ("cmm-calibrate", CMM_CAL),
    ("samba", SAMBA_CAL),
    ("long-term", LONG_TERM),
    ("task", TASK),
    ("validate-task", VALIDATE_TASK),
    ("pooling", POOLING),
    ("verify-length", (*VERIFY_LENGTH, "--temperature-c", "21.5")),
    ("design-compare", DESIGN_COMPARE),
]


def cases() -> list[Case]:
    """Every case of the extended corpus."""
    out = [
        Case(f"newer-{name}", mutate, tuple(args), names) for name, mutate, args, names in REFUSED
    ]
    out += [
        Case(f"newer-accepted-{name}", lambda f: f, tuple(args), None, expect="accepted")
        for name, args in ACCEPTED
    ]
    return out


__all__ = ["cases", "materialise", "valid_files"]
