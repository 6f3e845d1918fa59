"""Ballbar and R-test results in the history: each result kind maps to one category — the
ISO 230-4 analysis is a verification, the ballbar and R-test calibrations are calibrations
whose embedded parameter set (the machine's parameters and their covariance block, the
dynamic terms and nuisance unknowns left out) is what the run records."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.ballbar.diagnose import diagnose, simulate
from mtmetrology.ballbar.iso230_4 import circular_results
from mtmetrology.ballbar.records import BallbarConditions, nominal_test
from mtmetrology.ballbar.requests import CircularAnalysis
from mtmetrology.history.database import open_history
from mtmetrology.history.records import add_result, category_of, list_runs, show_run
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

CENTRE = np.array([1000.0, 300.0, 300.0])


@pytest.fixture(scope="module")
def machine():
    return Machine.load("three-axis-xfyz")


@pytest.fixture(scope="module")
def ballbar(machine):
    tests = [
        nominal_test(BallbarConditions("XY", r, 1000.0, CENTRE, name=f"XY{r:g}"), 360)
        for r in (100.0, 150.0)
    ]
    sim = simulate(machine, tests, {"E_C0Y": 20e-6, "E_XXb": 2e-3}, sigma=1e-4, seed=4)
    return sim, diagnose(machine, sim)


def test_each_kind_has_one_category(machine, ballbar):
    sim, diagnosis = ballbar
    calibration = diagnosis.to_dict(machine.name)
    analysis = CircularAnalysis(
        machine.name, tuple(sim), tuple(circular_results(t) for t in sim)
    ).to_dict()
    assert calibration["kind"] != analysis["kind"]
    for doc in (calibration, analysis):
        assert category_of(doc["kind"], "r.json") == doc["category"]
    assert category_of("r-test", "r.json") == "calibration"


def test_the_calibration_embeds_the_machines_parameters(machine, ballbar):
    _, diagnosis = ballbar
    doc = diagnosis.to_dict(machine.name)
    pset = ParameterSet.from_document(doc, machine, "ballbar.json")
    assert pset.names == diagnosis.machine.parameter_names
    rows = {r["name"]: r for r in doc["estimates"]}
    for name, value, u in zip(
        pset.names, pset.values / pset.scales(), pset.standard_uncertainty / pset.scales(),
        strict=True,
    ):  # fmt: skip
        assert value == pytest.approx(rows[name]["value"], rel=1e-12)
        assert u == pytest.approx(rows[name]["u"], rel=1e-9)
    assert abs(rows["E_C0Y"]["value"] - 20.0) < 4 * rows["E_C0Y"]["u"]


def test_history_records_calibration_and_verification(machine, ballbar, tmp_path):
    sim, diagnosis = ballbar
    engine = open_history(tmp_path / "h.db")
    add_result(engine, diagnosis.to_dict(machine.name), machine, source="cal.json", by="test")
    analysis = CircularAnalysis(machine.name, tuple(sim), tuple(circular_results(t) for t in sim))
    add_result(engine, analysis.to_dict(), machine, source="circ.json", by="test")
    (cal,) = list_runs(engine, machine=machine.name)
    (ver,) = list_runs(engine, machine=machine.name, category="verification")
    assert (cal.kind, ver.kind) == ("iso230-4-calibration", "iso230-4-circular")
    record = show_run(engine, cal.id)
    assert [p["name"] for p in record.parameters] == list(diagnosis.machine.parameter_names)
