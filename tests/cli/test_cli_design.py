"""mtm samba plan: programme file, JSON document, hand-over to mtm machine
identifiability, and bad input (exit 2, one line, nothing written)."""

import itertools
import json

import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app

runner = CliRunner()
MACHINE = ["--machine", "five-axis-wcbxfzyst"]
SMALL_GRID = """kind: samba-ball-grid
x_mm: [-80, 0, 80]
y_mm: [-40, 40]
stems_mm: [75, 150]
"""
BALLS = """kind: samba-balls
balls:
  - {id: "1", centre_mm: [-80, -40, 100]}
  - {id: "2", centre_mm: [80, -40, 150]}
  - {id: "3", centre_mm: [80, 120, 75]}
  - {id: "4", centre_mm: [-80, 120, 175]}
"""


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """1B.3n for the 13-parameter model from a small grid, with its artefact file."""
    d = tmp_path_factory.mktemp("design")
    (d / "grid.yaml").write_text(SMALL_GRID)
    args = [
        "samba", "plan", *MACHINE, "--model", "13", "--balls-from", str(d / "grid.yaml"),
        "--n-balls", "1", "--k", "3", "--starts", "2", "--seed", "7",
        "--b-grid", "-90:90:15", "--c-grid", "0:330:30",
        "-o", str(d / "prog.csv"), "--artefact-out", str(d / "art.yaml"), "--json",
    ]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    return d, json.loads(result.output)


def test_design_document_follows_eq_5_14(planned):
    _, doc = planned
    assert doc["kind"] == "samba-design" and doc["version"] == 1
    assert len(doc["balls"]) == 1 and doc["n_indexations"] == 21
    assert doc["n_measurements"] == 29  # 1B.3n of seed 004 Table 5.5
    assert doc["duration_h"] == pytest.approx(29 * 1.36 / 60)
    assert doc["rank"] == doc["n_unknowns"] == 13 + 3 * 3 + 3
    assert [p["name"] for p in doc["parameters"]][:2] == ["E_A0B", "E_C0B"]
    assert all(p["u"] > 0 for p in doc["parameters"])
    history = doc["step2"]["history"]
    assert all(b >= a for a, b in itertools.pairwise(history))


def test_identifiability_reads_the_programme_and_agrees(planned):
    """The programme is a ball-centre indication file: mtm machine identifiability gives
    the rank and condition number the design predicted (to the 1 nm rounding of the
    readings written in the file)."""
    d, doc = planned
    args = ["machine", "identifiability", "five-axis-wcbxfzyst", str(d / "prog.csv")]
    args += ["--model", "13", "--artefact", str(d / "art.yaml"), "--json"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    rep = json.loads(result.output)
    assert rep["rank"] == doc["rank"]
    assert rep["condition_scaled"] == pytest.approx(doc["condition_scaled"], rel=1e-6)


def test_84_model_programme_states_approach_senses(tmp_path):
    (tmp_path / "balls.yaml").write_text(BALLS)
    out = tmp_path / "prog.csv"
    args = ["samba", "plan", *MACHINE, "--model", "84", "--balls", str(tmp_path / "balls.yaml")]
    args += ["--k", "1", "--count-rule", "indexations", "--criterion", "D", "--starts", "1"]
    args += ["--seed", "1", "-o", str(out)]
    args += ["--b-grid", "-90:90:15", "--c-grid", "0:315:45"]
    args += ["--artefact-out", str(tmp_path / "art.yaml")]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    header = out.read_text().splitlines()[0].split(",")
    assert header == ["ball", "B", "C", "S", "X", "Y", "Z", "sense_B", "sense_C"]
    check = ["machine", "identifiability", "five-axis-wcbxfzyst", str(out), "--model", "84"]
    check += ["--artefact", str(tmp_path / "art.yaml"), "--json"]
    rep = json.loads(runner.invoke(app, check).output)
    assert rep["rank"] == rep["n_unknowns"] == 105


@pytest.mark.parametrize(
    ("extra", "names"),
    [
        (["--criterion", "G"], "--criterion"),
        (["--k", "-1"], "--k"),
        (["--b-grid", "180:180:1", "--c-grid", "0:90:90"], "accessib"),
        (["--count-rule", "nearest"], "--count-rule"),
    ],
)
def test_bad_input_exits_2_with_one_line_and_writes_nothing(tmp_path, extra, names):
    (tmp_path / "balls.yaml").write_text(BALLS)
    out = tmp_path / "prog.csv"
    args = ["samba", "plan", *MACHINE, "--model", "13", "--balls", str(tmp_path / "balls.yaml")]
    result = runner.invoke(app, [*args, *extra, "-o", str(out)])
    assert result.exit_code == 2
    assert result.output.startswith("error: ") and result.output.count("\n") == 1
    assert names.split()[0].lstrip("-") in result.output
    assert not out.exists()


def test_too_small_k_is_refused_naming_k(tmp_path):
    (tmp_path / "balls.yaml").write_text(BALLS)
    out = tmp_path / "prog.csv"
    args = ["samba", "plan", *MACHINE, "--model", "84", "--balls", str(tmp_path / "balls.yaml")]
    args += ["--k", "0.1", "--criterion", "D", "--starts", "1", "-o", str(out)]
    result = runner.invoke(app, args)
    assert result.exit_code == 2
    assert result.output.startswith("error: the best ")
    assert (
        "design found is rank deficient for the 84-parameter model, confounding " in result.output
    )
    assert "raise --k" in result.output and len(result.output.splitlines()) == 1
    assert not out.exists()


def test_default_count_rule_reproduces_4b5n_for_the_84_parameter_model(tmp_path):
    """`--model 84 --k 5` with 4 balls planned 165 indexations, 671 measurements, 15 h by
    default where the source's 4B.5n is 38, 163 and 3.7 h (Alami Mchichi 2018, Table 5.5;
    issue 18 §3): the default rule is the source's for the model, and the result says so."""
    (tmp_path / "balls.yaml").write_text(BALLS)
    args = [
        "samba", "plan", *MACHINE, "--model", "84", "--balls", str(tmp_path / "balls.yaml"),
        "--k", "5", "--criterion", "D", "--starts", "1", "--seed", "1",
        "-o", str(tmp_path / "p.csv"), "--json",
    ]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    doc = json.loads(result.output)
    assert doc["count_rule"] == "measurements"
    assert "84-parameter model" in doc["count_rule_reason"]
    assert (doc["n_indexations"], doc["n_measurements"]) == (38, 163)
    assert round(doc["duration_h"], 1) == 3.7
