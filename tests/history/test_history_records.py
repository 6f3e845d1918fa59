"""Tests for mtmetrology.history.records (SQLite and PostgreSQL)."""

from __future__ import annotations

import hashlib
from datetime import UTC, datetime, timedelta, timezone

import numpy as np
import pytest
from sqlalchemy import text

from mtmetrology.errors import InputError
from mtmetrology.history import (
    RunRecord,
    add_result,
    add_results,
    list_runs,
    open_history,
    show_run,
)
from mtmetrology.history.series import export_rows
from mtmetrology.kinematics.machine import Machine

MACHINE = Machine.load("five-axis-wcbxfzyst")


def test_a_calibration_round_trips_with_its_fields(history_url, make_calibration, tmp_path):
    engine = open_history(history_url)
    records = tmp_path / "records.csv"
    records.write_text("X,Y\n1,2\n")
    document = make_calibration([0.5 * k for k in range(13)], u=0.25)
    stored = add_result(
        engine,
        document,
        MACHINE,
        performed_at=datetime(2026, 3, 2, 8, 30),
        note="after the spindle change",
        artefact="SAMBA 4 balls",
        temperature_c=20.4,
        serial="SN-0042",
        input_files=(records,),
        by="test",
    )
    again = show_run(engine, stored.id)
    assert again == stored
    assert RunRecord.from_dict(stored.to_dict()) == stored
    assert stored.performed_at == datetime(2026, 3, 2, 8, 30, tzinfo=UTC)
    assert stored.operator_note == "after the spindle change"
    assert stored.temperature_c == 20.4
    assert stored.input_hashes == {str(records): hashlib.sha256(b"X,Y\n1,2\n").hexdigest()}
    assert [p["value"] for p in stored.parameters] == [0.5 * k for k in range(13)]
    assert [p["u"] for p in stored.parameters] == pytest.approx([0.25] * 13, rel=1e-12)
    assert [p["name"] for p in stored.parameters] == list(MACHINE.parameter_names)
    assert stored.result == document


def test_task_and_verification_results_go_to_their_tables(history_url):
    engine = open_history(history_url)
    name = MACHINE.name
    task = add_result(
        engine,
        {"kind": "uncertainty-result", "version": 2, "machine": name, "x": 1},
        MACHINE,
        by="test",
    )
    check = add_result(
        engine, {"kind": "length-check", "version": 1, "machine": name, "e": 2}, MACHINE, by="test"
    )
    assert (task.category, check.category) == ("task", "verification")
    assert [r.id for r in list_runs(engine, category="task")] == [task.id]
    assert list_runs(engine) == ()


def test_unknown_kind_is_refused_naming_the_file(history_url):
    engine = open_history(history_url)
    with pytest.raises(InputError, match=r"^r\.json: kind: 'fit-result' is not a result"):
        add_result(
            engine, {"kind": "fit-result", "version": 1}, MACHINE, source="r.json", by="test"
        )


def test_a_calibration_of_another_machine_is_refused(history_url, make_calibration):
    engine = open_history(history_url)
    other = Machine.load("three-axis-xfyz")
    both = "a result of machine 'five-axis-wcbxfzyst', not of machine 'three-axis-xfyz'"
    with pytest.raises(InputError, match=f"^cal.json: {both}"):
        add_result(engine, make_calibration([0.0] * 13), other, source="cal.json", by="test")
    document = make_calibration([0.0] * 13)
    document["machine"] = "another-machine"
    with pytest.raises(InputError, match="machine 'another-machine', not of machine 'five-"):
        add_result(engine, document, MACHINE, source="cal.json", by="test")
    assert list_runs(engine) == ()


def test_parameters_that_differ_from_the_machines_history_are_refused(
    history_url, make_calibration
):
    engine = open_history(history_url)
    add_result(engine, make_calibration([0.0] * 13), MACHINE, by="test")
    shorter = make_calibration([1.0] * 13)
    shorter["parameters"] = shorter["parameters"][:12]
    del shorter["covariance"]
    with pytest.raises(InputError, match=r"parameters differ .*\(not in both: E_X0S\)"):
        add_result(engine, shorter, MACHINE, source="cal2.json", by="test")
    assert len(list_runs(engine)) == 1


def test_list_filters_and_export_rows(history_url, make_calibration):
    engine = open_history(history_url)
    for day in (3, 1, 2):
        add_result(
            engine,
            make_calibration([float(day)] * 13),
            MACHINE,
            performed_at=datetime(2026, 1, day),
            by="test",
        )
    runs = list_runs(engine, since=datetime(2026, 1, 2))
    assert [r.performed_at.day for r in runs] == [2, 3]
    rows = export_rows(engine, MACHINE.name)
    assert [row["E_X0C [µm]"] for row in rows] == [1.0, 2.0, 3.0]
    with pytest.raises(InputError, match="machine 'nope': not in the history"):
        export_rows(engine, "nope")


def test_a_recorded_covariance_asymmetric_by_rounding_comes_back_exactly_symmetric():
    """document_covariance applies the one reader rule (mtmetrology.io.covariance)."""
    from mtmetrology.history.series import document_covariance
    from mtmetrology.io.files import InputFileError

    doc = {
        "parameters": [{"name": "E_X0C", "unit": "µm"}, {"name": "E_A0B", "unit": "µrad"}],
        "covariance": {"names": ["E_X0C", "E_A0B"], "matrix": [[0.25, 1e-7], [1e-7 + 3e-16, 1]]},
    }
    c = document_covariance(doc, ["E_A0B", "E_X0C"])
    np.testing.assert_array_equal(c, c.T)
    doc["covariance"]["matrix"][1][0] = 1e-7 + 1e-6
    with pytest.raises(InputFileError, match=r"^run 4: covariance\.matrix: covariance matrix"):
        document_covariance(doc, ["E_X0C", "E_A0B"], "run 4")


def test_a_date_with_an_offset_is_the_same_instant_on_every_backend(history_url, make_calibration):
    """08:00+02:00 is 06:00 UTC in the database on SQLite as on PostgreSQL (SQLite stored
    08:00 before schema 0004), the record gives it back in the offset it was given in, and
    runs sort by instant: 07:00+00:00 comes after 08:00+02:00."""
    engine = open_history(history_url)
    plus_two = timezone(timedelta(hours=2))
    first = add_result(
        engine,
        make_calibration([1.0] * 13),
        MACHINE,
        performed_at=datetime(2025, 1, 6, 8, 0, tzinfo=plus_two),
        by="test",
    )
    add_result(
        engine,
        make_calibration([2.0] * 13),
        MACHINE,
        performed_at=datetime(2025, 1, 6, 7, 0, tzinfo=UTC),
        by="test",
    )
    assert first.performed_at == datetime(2025, 1, 6, 6, 0, tzinfo=UTC)
    assert first.performed_at.utcoffset() == timedelta(hours=2)
    assert show_run(engine, first.id).to_dict()["performed_at"] == "2025-01-06T08:00:00+02:00"
    assert [r.performed_at.hour for r in list_runs(engine)] == [8, 7]
    assert [r.id for r in list_runs(engine)] == [1, 2]
    assert [r.id for r in list_runs(engine, since=datetime(2025, 1, 6, 6, 30))] == [2]
    with engine.connect() as c:
        if engine.dialect.name == "sqlite":
            stored = c.execute(text("SELECT performed_at FROM calibration_runs WHERE id = 1"))
            assert stored.scalar().startswith("2025-01-06 06:00:00")
        else:
            stored = c.execute(
                text("SELECT performed_at AT TIME ZONE 'UTC' FROM calibration_runs WHERE id = 1")
            )
            assert stored.scalar() == datetime(2025, 1, 6, 6, 0)


def _refused(engine, document, machine=MACHINE, **options) -> str:
    with pytest.raises(InputError) as raised:
        add_result(engine, document, machine, source="r.json", **options, by="test")
    return str(raised.value)


def test_documents_that_cannot_be_a_result_of_the_machine_are_refused_naming_both(
    tmp_path, make_calibration
):
    engine = open_history(tmp_path / "h.sqlite")
    cmm = Machine.load("three-axis-xfyz")
    assert _refused(engine, {"a": 1}) == (
        "r.json: not a result document (no kind; the history records the results of the "
        "calibrate, task and verify commands)"
    )
    assert _refused(engine, [1, 2]).startswith("r.json: not a result document")
    assert _refused(engine, make_calibration([0.0] * 13), cmm) == (
        "r.json: a result of machine 'five-axis-wcbxfzyst', not of machine 'three-axis-xfyz' "
        "(--machine)"
    )
    # a generic GUM result (mtm uncertainty, e.g. JCGM 100 H.1) is no machine's task result
    gum = {"kind": "uncertainty-result", "version": 2, "method": "guf", "outputs": []}
    assert _refused(engine, gum) == (
        "r.json: a result of kind 'uncertainty-result' that names no machine (no machine "
        "field) is not a task result of machine 'five-axis-wcbxfzyst'"
    )
    wrong = {"kind": "length-check", "version": 1, "machine": MACHINE.name, "category": "task"}
    assert _refused(engine, wrong) == (
        "r.json: category: 'task', but a 'length-check' is a verification result"
    )
    for temperature in (float("nan"), -300.0, 150.0):
        message = _refused(engine, make_calibration([0.0] * 13), temperature_c=temperature)
        assert message.endswith("°C: not a workshop temperature (-50 to 100 °C)")
    assert list_runs(engine) == () and list_runs(engine, category="task") == ()


def test_several_results_are_recorded_all_or_none(tmp_path, make_calibration):
    engine = open_history(tmp_path / "h.sqlite")
    add_result(engine, make_calibration([0.0] * 13), MACHINE, source="a.json", by="test")
    items = [
        {"document": make_calibration([float(k)] * 13), "machine": MACHINE, "source": f"{k}.json"}
        for k in (1, 2, 0)
    ]
    with pytest.raises(InputError, match=r"^0\.json: already recorded as calibration run 1$"):
        add_results(engine, items, by="test")
    assert [r.id for r in list_runs(engine)] == [1]
    with pytest.raises(InputError, match=r"^2\.json: the same result as 1\.json \(given twice\)"):
        add_results(engine, [items[0], {**items[0], "source": "2.json"}], by="test")
    records = add_results(engine, items[:2], by="test")
    assert [r.parameters[0]["value"] for r in records] == [1.0, 2.0]
    assert [r.id for r in list_runs(engine)] == [1, 2, 3]


def test_the_calibration_kinds_are_those_of_the_parameter_set_reader():
    """records spells them to keep kinematics off the read path; they must agree."""
    from mtmetrology.history.records import CALIBRATION_KINDS
    from mtmetrology.kinematics.parameter_set import KIND, RESULT_KINDS

    assert CALIBRATION_KINDS == (KIND, *RESULT_KINDS)


def _audit_rows(engine) -> list[dict]:
    from sqlalchemy.orm import Session

    from mtmetrology.history.audit import audit_entries

    with Session(engine) as session:
        return audit_entries(session)[::-1]


def test_cli_add_writes_one_audit_row_per_file_and_a_refusal_none(
    history_url, make_calibration, tmp_path, monkeypatch
):
    import getpass
    import json

    from typer.testing import CliRunner

    from mtmetrology.cli import app

    files = []
    for k in range(3):
        files.append(tmp_path / f"cal{k}.json")
        files[-1].write_text(json.dumps(make_calibration([float(k)] * 13)))

    def mtm(*args):
        return CliRunner().invoke(app, ["history", "add", *map(str, args), "--db", history_url])

    assert mtm(files[0], files[1], "--by", "ada").exit_code == 0
    monkeypatch.setattr(getpass, "getuser", lambda: "lab")
    assert mtm(files[2]).exit_code == 0
    engine = open_history(history_url)
    rows = _audit_rows(engine)
    assert [(r["actor"], r["action"], r["target"]) for r in rows] == [
        ("cli:ada", "add", "calibration run 1"),
        ("cli:ada", "add", "calibration run 2"),
        ("cli:lab", "add", "calibration run 3"),
    ]
    assert [r["detail"]["file"] for r in rows] == [str(f) for f in files]
    assert [r["detail"]["content_sha256"] for r in rows] == [
        show_run(engine, k).content_sha256 for k in (1, 2, 3)
    ]
    assert [r["detail"]["new_machine"] for r in rows] == [True, False, False]
    # the second file is refused (recorded before): neither run nor audit row is written
    fresh = tmp_path / "cal3.json"
    fresh.write_text(json.dumps(make_calibration([7.0] * 13)))
    refused = mtm(fresh, files[0])
    assert refused.exit_code == 2
    assert len(_audit_rows(engine)) == 3 and len(list_runs(engine)) == 3


def test_a_failing_audit_write_records_no_result(tmp_path, make_calibration, monkeypatch):
    from mtmetrology.history import records

    engine = open_history(tmp_path / "h.sqlite")

    def broken(*args, **kwargs):
        raise RuntimeError("crash between the run and its audit row")

    monkeypatch.setattr(records, "write_audit", broken)
    with pytest.raises(RuntimeError):
        add_result(engine, make_calibration([1.0] * 13), MACHINE, by="test")
    assert list_runs(engine) == ()
    monkeypatch.undo()
    with pytest.raises(InputError, match=r"^history add: name who records the results \(by\)$"):
        add_result(engine, make_calibration([1.0] * 13), MACHINE, by=" ")
    assert list_runs(engine) == () and _audit_rows(engine) == []
