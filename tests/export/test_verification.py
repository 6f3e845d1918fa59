"""The verification of compensation tables on the machine (issue 29): the check programme
reaches every check point with the stated sense of travel, and the template holds the
prediction of the export at those points (with a reversal term: the closed-form error in
each direction)."""

from __future__ import annotations

import csv
import io
import re

import numpy as np
import pytest

from mtmetrology.export.verification import (
    DIALECTS,
    TEMPLATE,
    export_with_verification,
    plan_checks,
    programme,
)
from mtmetrology.export.workflow import export_compensation
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

MACHINE = Machine.load("three-axis-xfyz")


def _rows(text: str) -> tuple[list[str], list[dict]]:
    body = "\n".join(ln for ln in text.splitlines() if not ln.startswith("#"))
    reader = csv.DictReader(io.StringIO(body))
    return reader.fieldnames, list(reader)


def test_template_holds_the_export_prediction_at_the_check_points(exported):
    """r, U and e of the template are those of export_compensation(at=, at_senses=) at the
    template's readings and senses (to the 4 decimals written)."""
    pset, _, files = exported
    _, rows = _rows(files[TEMPLATE])
    q = MACHINE.readings_from_customary(np.array([[float(r[a]) for a in "XYZ"] for r in rows]))
    s = np.array([[float(r[f"sense_{a}"]) for a in "XYZ"] for r in rows])
    lib = export_compensation(MACHINE, pset, "linuxcnc", pitch=20, at=q, at_senses=s)
    for key, prefix in (("r", "r"), ("U", "U"), ("e", "e")):
        got = np.array([[float(r[f"{prefix}{c}_um"]) for c in "xyz"] for r in rows])
        np.testing.assert_allclose(got, lib.at_points[key], atol=6e-5)
    assert {r["mx_um"] for r in rows} == {""}


def test_the_users_at_points_keep_their_place(exported):
    """With --at too, check.json's at_points are the user's points only, as without the
    verification."""
    pset, _, _ = exported
    at = MACHINE.readings_from_customary(np.array([[900.0, 200.0, 250.0], [1111, 333, 377]]))
    with_v, _ = export_with_verification(
        MACHINE, pset, "linuxcnc", verify_positions=3, pitch=20, at=at
    )
    alone = export_compensation(MACHINE, pset, "linuxcnc", pitch=20, at=at)
    assert with_v.to_dict() == alone.to_dict()


def _run(text: str, dialect) -> list[tuple[dict, dict]]:
    """Execute a check programme: at each dwell, the axis positions and the sign of each
    axis's last move."""
    position, last, out = {}, {}, []
    comment = re.compile(r"^\(.*\)$|^;") if "(" in dialect.comment else re.compile(r"^;")
    dwell = dialect.dwell.split()[0]
    for line in text.splitlines():
        if comment.match(line) or line in (*dialect.start, *dialect.end, dialect.metric):
            continue
        words = line.split()
        if words[0] == dwell:
            out.append((dict(position), dict(last)))
            continue
        assert words[0] == "G01", line
        for w in words[1:]:
            if w[0] == "F":
                continue
            value = float(w[1:])
            assert "." in w[1:], f"{w}: a position without a decimal point"
            if w[0] in position and value != position[w[0]]:
                last[w[0]] = np.sign(value - position[w[0]])
            position[w[0]] = value
    return out


@pytest.mark.parametrize("fmt", list(DIALECTS))
def test_programme_reaches_every_check_point_with_its_sense_of_travel(fmt):
    plan = plan_checks(MACHINE, positions=4, overrun_mm=3.0)
    name, text = programme(plan, fmt, ["x.comp"])
    assert name == DIALECTS[fmt].file
    stops = _run(text, DIALECTS[fmt])
    assert len(stops) == len(plan.points) == 3 * 2 * 4
    for i, (position, last) in enumerate(stops):
        for k, a in enumerate(plan.axis_names):
            assert position[a] == pytest.approx(plan.readings[i, k], abs=5e-4)
            assert last[a] == plan.senses[i, k], (plan.points[i], a)
    assert text.rstrip().endswith(DIALECTS[fmt].end[-1])
    if "(" in DIALECTS[fmt].comment:  # a comment in parentheses holds none
        for line in text.splitlines():
            if line.startswith("("):
                assert line.count("(") == 1 and line.count(")") == 1, line


def test_plan_refuses_a_rotary_axis_and_an_overrun_beyond_the_travel():
    five = Machine.load("five-axis-wcbxfzyst")
    with pytest.raises(ValueError, match="rotary axis"):
        plan_checks(five, ["B"])
    with pytest.raises(ValueError, match="--verify-overrun"):
        plan_checks(MACHINE, ["Z"], overrun_mm=500)
    with pytest.raises(ValueError, match="--verify-positions"):
        plan_checks(MACHINE, positions=1)


def test_the_template_carries_the_sense_of_travel_into_the_prediction(reversal_machine):
    """E_XX1 = 50 µm/m and a reversal E_XXb = 5 µm: the uncompensated error of the template
    is the closed form e_x = 0.05 µm/mm · x + 5 µm · sense, and LinuxCNC's per-direction
    table removes it in both directions."""
    m = reversal_machine
    pset = ParameterSet(
        ("E_XX1", "E_XXb"),
        np.array([50e-6, 5e-3]),
        ("µm/m", "µm"),
        np.diag([1e-14, 1e-8]),
        machine=m.name,
    )
    _, files = export_with_verification(m, pset, "linuxcnc", verify_positions=4, pitch=10)
    _, rows = _rows(files[TEMPLATE])
    x = [r for r in rows if r["axis"] == "X"]
    assert len(x) == 8 and {r["sense_X"] for r in x} == {"+1", "-1"}
    for r in x:
        e = 0.05 * float(r["X"]) + 5.0 * float(r["sense_X"])
        assert float(r["ex_um"]) == pytest.approx(e, abs=1e-4)
        assert abs(float(r["rx_um"])) < 0.01 * abs(e)
