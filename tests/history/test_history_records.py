"""Tests for mtmetrology.history.records (SQLite and PostgreSQL)."""

from __future__ import annotations

import hashlib
from datetime import UTC, datetime

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.history import RunRecord, add_result, list_runs, open_history, show_run
from mtmetrology.history.records import export_rows
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
        engine, {"kind": "uncertainty-result", "version": 2, "machine": name, "x": 1}, MACHINE
    )
    check = add_result(
        engine, {"kind": "length-check", "version": 1, "machine": name, "e": 2}, MACHINE
    )
    assert (task.category, check.category) == ("task", "verification")
    assert [r.id for r in list_runs(engine, category="task")] == [task.id]
    assert list_runs(engine) == ()


def test_unknown_kind_is_refused_naming_the_file(history_url):
    engine = open_history(history_url)
    with pytest.raises(InputError, match=r"^r\.json: kind: 'fit-result' is not a result"):
        add_result(engine, {"kind": "fit-result", "version": 1}, MACHINE, source="r.json")


def test_a_calibration_of_another_machine_is_refused(history_url, make_calibration):
    engine = open_history(history_url)
    other = Machine.load("three-axis-xfyz")
    both = "a result of machine 'five-axis-wcbxfzyst', not of machine 'three-axis-xfyz'"
    with pytest.raises(InputError, match=f"^cal.json: {both}"):
        add_result(engine, make_calibration([0.0] * 13), other, source="cal.json")
    document = make_calibration([0.0] * 13)
    document["machine"] = "another-machine"
    with pytest.raises(InputError, match="machine 'another-machine', not of machine 'five-"):
        add_result(engine, document, MACHINE, source="cal.json")
    assert list_runs(engine) == ()


def test_parameters_that_differ_from_the_machines_history_are_refused(
    history_url, make_calibration
):
    engine = open_history(history_url)
    add_result(engine, make_calibration([0.0] * 13), MACHINE)
    shorter = make_calibration([1.0] * 13)
    shorter["parameters"] = shorter["parameters"][:12]
    del shorter["covariance"]
    with pytest.raises(InputError, match=r"parameters differ .*\(not in both: E_X0S\)"):
        add_result(engine, shorter, MACHINE, source="cal2.json")
    assert len(list_runs(engine)) == 1


def test_list_filters_and_export_rows(history_url, make_calibration):
    engine = open_history(history_url)
    for day in (3, 1, 2):
        add_result(
            engine,
            make_calibration([float(day)] * 13),
            MACHINE,
            performed_at=datetime(2026, 1, day),
        )
    runs = list_runs(engine, since=datetime(2026, 1, 2))
    assert [r.performed_at.day for r in runs] == [2, 3]
    rows = export_rows(engine, MACHINE.name)
    assert [row["E_X0C [µm]"] for row in rows] == [1.0, 2.0, 3.0]
    with pytest.raises(InputError, match="machine 'nope': not in the history"):
        export_rows(engine, "nope")


def test_a_recorded_covariance_asymmetric_by_rounding_comes_back_exactly_symmetric():
    """document_covariance applies the one reader rule (mtmetrology.io.covariance)."""
    from mtmetrology.history.records import document_covariance
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
