"""``mtm samba simulate`` with two styli: records with a ``tool`` column that ``mtm
samba calibrate`` reads back, and the round trip that recovers E_AY1 and E_YY1, the pair
one stylus length confounds (Alami Mchichi (2018) Table 4.4)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.io.files import InputFileError
from mtmetrology.samba import ProbingProgramme, simulate_records

from .samba_helpers import EXAMPLES, MACHINE

runner = CliRunner()
TOOLS = {"long": (0.0, 0.0, -150.0), "short": (0.0, 0.0, -200.0)}
#: 13 parameters of the example model plus E_AY1 (Y-axis roll about A, proportional to y)
PARAMS = [
    "E_A0B", "E_C0B", "E_X0C", "E_A0C", "E_B0C", "E_B0Z", "E_A0Y", "E_C0Y",
    "E_XX1", "E_YY1", "E_ZZ1", "E_Y0S", "E_X0S", "E_AY1",
]  # fmt: skip


def mtm(*args):
    return runner.invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("styli")
    art = yaml.safe_load((EXAMPLES / "artefact.yaml").read_text())
    art["tools"] = [{"id": t, "vector_mm": list(v)} for t, v in TOOLS.items()]
    (tmp / "artefact.yaml").write_text(yaml.safe_dump(art))
    truth = json.loads((EXAMPLES / "truth.json").read_text())
    truth.pop("model")
    truth["parameters"].append({"name": "E_AY1", "value": 300.0, "unit": "µrad/m"})
    (tmp / "truth.json").write_text(json.dumps(truth))
    return tmp


def simulate(files, out, *tools, noise="0.5"):
    args = ["samba", "simulate", "--machine", MACHINE, "--truth", files / "truth.json"]
    args += ["--artefact", files / "artefact.yaml", "--balls", EXAMPLES / "balls.yaml"]
    args += ["--poses", EXAMPLES / "poses.csv", "--noise-um", noise, "--seed", "5", "-o", out]
    for t in tools:
        args += ["--tool", f"{t}={','.join(str(v) for v in TOOLS[t])}"]
    return mtm(*args)


def calibrate(files, records):
    return mtm(
        "samba", "calibrate", records, "--machine", MACHINE, "--artefact",
        files / "artefact.yaml", "--params-only", ",".join(PARAMS), "--estimate-tool",
        "--noise-um", "0.5", "--json",
    )  # fmt: skip


def test_two_styli_write_a_tool_column_repeating_the_programme(files):
    out = files / "two.csv"
    result = simulate(files, out, "long", "short")
    assert result.exit_code == 0, result.output
    lines = out.read_text().splitlines()
    assert lines[0].split(",")[-1] == "tool"
    tools = [r.split(",")[-1] for r in lines[1:]]
    n = (len(lines) - 1) // 2
    assert tools == ["long"] * n + ["short"] * n
    # the same ball in the same pose read with a 50 mm longer stylus along −z: at
    # B = C = 0 the Z reading is higher by 50 mm less the small Z-scale error
    first, second = lines[1].split(","), lines[1 + n].split(",")
    assert first[0] == second[0]
    assert float(second[3]) - float(first[3]) == pytest.approx(50.0, abs=0.02)


def test_round_trip_recovers_the_pair_one_stylus_confounds(files):
    """Simulate with the known 14-parameter set and two styli, 0.5 µm noise, calibrate:
    every parameter within 4 u of its truth (u from the identification's covariance;
    P(|z| > 4) = 6e-5 per parameter), and E_AY1 resolved with u well below its value."""
    out = files / "rt.csv"
    assert simulate(files, out, "long", "short").exit_code == 0
    result = calibrate(files, out)
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["identification"]["rank"] == doc["identification"]["unknowns"]
    truth = {p["name"]: p["value"] for p in json.loads((files / "truth.json").read_text())[
        "parameters"
    ]}  # fmt: skip
    got = {p["name"]: p for p in doc["parameters"]}
    for name in PARAMS:
        u = got[name]["u"]
        assert abs(got[name]["value"] - truth[name]) < 4 * u, name
    assert got["E_AY1"]["unit"] == "µrad/m"
    assert got["E_AY1"]["value"] > 4 * got["E_AY1"]["u"]  # resolved: 300 µrad/m stands out
    tools = {t["id"]: t["vector_mm"] for t in doc["tools"]}
    np.testing.assert_allclose(tools["short"], TOOLS["short"], atol=0.005)


def test_one_stylus_leaves_the_pair_confounded(files):
    out = files / "one.csv"
    assert simulate(files, out, "long").exit_code == 0
    result = calibrate(files, out)
    assert result.exit_code == 2
    assert "E_AY1" in result.output and "second stylus length" in result.output


def test_a_tool_missing_from_the_artefact_is_refused(files, machine13, balls, artefact):
    prog = ProbingProgramme(("1", "1"), np.zeros(2), np.array([0.0, 90.0]), np.zeros(2))
    with pytest.raises(InputFileError, match="tool 'long' is not in the artefact's tools"):
        simulate_records(machine13, None, balls, prog, artefact, tools={"long": TOOLS["long"]})
    named = ProbingProgramme(prog.balls, prog.b_deg, prog.c_deg, prog.s_deg, ("a", "a"))
    with pytest.raises(InputFileError, match="a tool column needs the styli"):
        simulate_records(machine13, None, balls, named, artefact)
    result = mtm(
        "samba", "simulate", "--machine", MACHINE, "--artefact", files / "artefact.yaml",
        "--balls", EXAMPLES / "balls.yaml", "--poses", EXAMPLES / "poses.csv",
        "--tool", "long=0,0", "-o", files / "never.csv",
    )  # fmt: skip
    assert result.exit_code == 2 and "--tool long needs three numbers" in result.output
    assert not (files / "never.csv").exists()
