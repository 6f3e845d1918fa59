"""``mtm history amend`` and the amendments in ``mtm history show`` (SQLite file)."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

runner = CliRunner()
MACHINE = Machine.load("five-axis-wcbxfzyst")


def _mtm(*args):
    return runner.invoke(app, [str(a) for a in args])


def test_amend_then_show(tmp_path):
    db, cal = tmp_path / "h.sqlite", tmp_path / "cal.json"
    ParameterSet(
        MACHINE.parameter_names,
        MACHINE.parameter_scales,
        MACHINE.parameter_units,
        machine=MACHINE.name,
        model="13",
    ).save(cal)
    assert _mtm("history", "add", cal, "--db", db).exit_code == 0
    r = _mtm(
        "history", "amend", "1", "--db", db, "--date", "2025-01-06T08:00+02:00",
        "--operator", "ada", "--why", "added without --date", "--by", "lab", "--json",
    )  # fmt: skip
    assert r.exit_code == 0, r.output
    made = json.loads(r.stdout)["amendments"]
    assert [a["field"] for a in made] == ["performed_at", "operator"]
    assert made[0]["new_value"] == "2025-01-06T06:00:00+00:00"
    assert made[0]["amended_by"] == "cli:lab"
    shown = json.loads(_mtm("history", "show", "1", "--db", db, "--json").stdout)
    # the run shows the date in the offset it was given in (schema 0004): the same instant
    assert shown["performed_at"] == "2025-01-06T08:00:00+02:00"
    assert [a["field"] for a in shown["amendments"]] == ["performed_at", "operator"]
    # no reason, no change: refused with exit 2, nothing recorded
    assert _mtm("history", "amend", "1", "--db", db, "--note", "x").exit_code == 2
    assert _mtm("history", "amend", "1", "--db", db, "--why", "w").exit_code == 2
    again = json.loads(_mtm("history", "show", "1", "--db", db, "--json").stdout)
    assert len(again["amendments"]) == 2
