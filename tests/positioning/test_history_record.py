"""An ISO 230-2 laser result becomes a history record: its E_XX terms as the run's
parameters, E, A, R, B and M in its statistics, in the order of the runs."""

from __future__ import annotations

from datetime import UTC, datetime

import numpy as np

from mtmetrology.history.database import open_history
from mtmetrology.history.records import add_result, list_runs, show_run
from mtmetrology.history.series import parameter_series
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.positioning.identify import axis_machine
from mtmetrology.positioning.simulate import iso_targets, simulate_test
from mtmetrology.positioning.workflow import analyse


def test_two_laser_runs_trend_e_a_r_b(tmp_path):
    m = Machine.load("three-axis-xfyz")
    sub = axis_machine(m, "X")
    engine = open_history(tmp_path / "h.db")
    docs = []
    for k, slope in enumerate((0.010, 0.014)):  # the positioning slope grows between runs
        truth = ParameterSet(
            sub.parameter_names, np.array([slope, 0.0, 0.0, 0.002]), sub.parameter_units,
            machine=m.name,
        )  # fmt: skip
        test = simulate_test(m, truth, "X", iso_targets(800, 1200, 9, seed=1), seed=k)
        docs.append(analyse(test, machine=m).to_dict())
        when = datetime(2026, 11, 1 + 7 * k, tzinfo=UTC)
        add_result(engine, docs[-1], m, source=f"laser{k}.json", performed_at=when, by="test")
    runs = list_runs(engine, machine=m.name)
    assert [r.kind for r in runs] == ["iso230-2-positioning"] * 2
    stats = [show_run(engine, r.id).residual_statistics for r in runs]
    for key in ("E", "A", "R", "B"):
        assert [s[f"iso230_2_{key}_um"] for s in stats] == [d["iso230_2"][key] for d in docs]
    assert stats[1]["iso230_2_E_um"] > stats[0]["iso230_2_E_um"]
    _, _, unit, values, _ = parameter_series(engine, m.name, "E_XX1")
    assert unit == "µm" and values[1] > values[0]
