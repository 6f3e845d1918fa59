"""DETMAX step 1 (ball choice) with several styli (issue 25; Alami Mchichi (2018) §5.5 and
Table 4.4): every candidate ball is scored with its rows probed by each stylus, so the
exchange maximises the criterion of the multi-stylus information matrix."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.design.accessibility import AccessibilityRule
from mtmetrology.design.inputs import grid_indexations
from mtmetrology.design.samba import ball_information, choose_balls, plan_samba
from mtmetrology.errors import RankDeficientError
from mtmetrology.kinematics import Machine

PAIRS = grid_indexations(np.arange(-90, 91, 30), np.arange(0, 360, 45))
STYLI = [("long", (0.0, 0.0, -150.0)), ("short", (0.0, 0.0, -200.0))]
VECTORS = np.array([v for _, v in STYLI])
FREE = AccessibilityRule(check_travel=False)
IDS = list("abcdef")
CANDIDATES = np.array(
    [[-50, -50, 50], [50, 50, 60], [0, 40, 75], [160, 120, 75], [-120, 80, 150], [100, -80, 125]],
    dtype=float,
)


@pytest.fixture(scope="module")
def m14():
    """13 parameters + E_AY1: one stylus leaves E_AY1 ~ E_YY1 confounded (Table 4.4)."""
    m = Machine.load("five-axis-wcbxfzyst", "13")
    return m.with_parameters([*m.parameter_names, "E_AY1"])


def test_two_styli_step1_can_only_gain_over_the_one_stylus_choice(m14):
    """log det of the two-stylus information (D, fixed column scaling) at the balls that
    step 1 chooses with both styli ≥ at the balls it chooses with one stylus; here the
    second stylus changes the choice, so strictly. DETMAX's choice is also the exhaustive
    optimum over the 15 pairs of 6 candidates."""
    kw = {"criterion": "D", "rule": FREE, "starts": 2, "seed": 0}
    one_ids, _, _ = choose_balls(m14, IDS, CANDIDATES, 2, PAIRS, **kw)
    two_ids, _, two = choose_balls(m14, IDS, CANDIDATES, 2, PAIRS, tools=VECTORS, **kw)
    space = ball_information(m14, IDS, CANDIDATES, PAIRS, criterion="D", rule=FREE, tools=VECTORS)
    at_one = space.value(space.start([IDS.index(b) for b in one_ids]))
    assert two.best.value > at_one
    best = max(space.value(space.start(list(s))) for s in itertools.combinations(range(6), 2))
    assert two.best.value == best
    assert set(two_ids) != set(one_ids)


def test_step1_and_step2_with_two_styli_give_a_full_rank_plan(m14):
    """Balls from candidates, two styli: full rank, E_AY1 and E_YY1 resolved; the same
    candidates with one stylus are refused naming the confounded pair."""
    kw = {"candidates": (IDS, CANDIDATES), "n_balls": 2, "k": 3, "criterion": "D"}
    kw |= {"rule": FREE, "starts": 1, "seed": 0}
    d = plan_samba(m14, PAIRS, tools=STYLI, **kw)
    doc = d.to_dict()
    assert doc["rank"] == doc["n_unknowns"] and doc["condition_scaled"] is not None
    assert doc["step1"] is not None and len(doc["balls"]) == 2
    assert doc["stylus_gain"]["resolved"] == ["E_AY1", "E_YY1"]
    assert (
        doc["stylus_gain"]["one_stylus"]["rank"]
        == doc["stylus_gain"]["one_stylus"]["n_unknowns"] - 1
    )
    with pytest.raises(RankDeficientError) as err:
        plan_samba(m14, PAIRS, **kw)
    assert [set(g) for g in err.value.confounded] == [{"E_AY1", "E_YY1"}]


@pytest.mark.parametrize("criterion", ["D", "O1", "O2", "A"])
def test_one_stylus_step1_is_the_multi_stylus_path_with_one_tool(criterion):
    """No ``tools`` and the machine's own tool given as the one stylus build the same
    information bit for bit, so the one-stylus step 1 is unchanged (same balls, same
    criterion value of every DETMAX run)."""
    m = Machine.load("five-axis-wcbxfzyst", "13")
    cands = np.array([[0, 40, 75], [0, 40, 175], [160, 120, 75], [160, 120, 175]], float)
    pairs = grid_indexations(np.arange(-90, 91, 45), np.arange(0, 360, 60))
    kw = {"criterion": criterion, "starts": 3, "seed": 0}
    ids0, c0, r0 = choose_balls(m, list("abcd"), cands, 2, pairs, **kw)
    ids1, c1, r1 = choose_balls(m, list("abcd"), cands, 2, pairs, tools=np.array([m.tool]), **kw)
    assert ids0 == ids1 and np.array_equal(c0, c1)
    assert [r.value for r in r0.runs] == [r.value for r in r1.runs]
    assert [r.start_value for r in r0.runs] == [r.start_value for r in r1.runs]


def test_cli_chooses_balls_with_two_styli(tmp_path):
    grid = tmp_path / "grid.yaml"
    grid.write_text("kind: samba-ball-grid\nx_mm: [-80, 80]\ny_mm: [-40, 40]\nstems_mm: [75]\n")
    names = "E_A0B,E_C0B,E_X0C,E_A0C,E_B0C,E_B0Z,E_A0Y,E_C0Y,E_XX1,E_YY1,E_ZZ1,E_Y0S,E_X0S,E_AY1"
    out = tmp_path / "plan.csv"
    args = ["samba", "plan", "--machine", "five-axis-wcbxfzyst", "--params-only", names]
    args += ["--balls-from", str(grid), "--n-balls", "2", "--criterion", "D"]
    args += ["--b-grid", "-90:90:30", "--c-grid", "0:315:45", "--starts", "1", "--seed", "0"]
    args += ["--tool", "long=0,0,-150", "--tool", "short=0,0,-200", "-o", str(out), "--json"]
    result = CliRunner().invoke(app, args)
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert len(doc["balls"]) == 2 and doc["step1"]["criterion"] == "D"
    planned = {r.split(",")[0] for r in out.read_text().splitlines()[1:]}
    assert {b["id"] for b in doc["balls"]} <= planned
    assert doc["rank"] == doc["n_unknowns"]
    assert doc["stylus_gain"]["resolved"] == ["E_AY1", "E_YY1"]


def test_step1_information_is_the_gram_matrix_of_the_two_stylus_programme(m14):
    """F(S) that step 1 scores is JᵀJ of the identification Jacobian of the programme
    (fixed rows, each ball at B = C = 0 and at every pair where both styli reach it, all
    probed with each stylus): equal spectra after unit-diagonal scaling (which undoes any
    column scaling of either)."""
    from mtmetrology.design.criteria import scaled_spectrum
    from mtmetrology.design.inputs import ScaleBarPlacement
    from mtmetrology.design.programme import (
        ProgrammeRows,
        accessible_all,
        approach_senses,
        fixed_programme_rows,
        nominal_jacobian,
        per_tool,
        programme_problem,
    )

    chosen = [3, 4]
    space = ball_information(m14, IDS, CANDIDATES, PAIRS, criterion="D", rule=FREE, tools=VECTORS)
    bar = ScaleBarPlacement()
    mask = accessible_all(m14, FREE, CANDIDATES, PAIRS, VECTORS, obstacles=False)
    senses = approach_senses(len(PAIRS))
    parts = [fixed_programme_rows(bar, [IDS[i] for i in chosen])]
    for i in chosen:
        ok = np.flatnonzero(mask[:, i])
        parts.append(
            ProgrammeRows([IDS[i]] * ok.size, PAIRS[ok, 0], PAIRS[ok, 1], np.zeros(ok.size),
                          senses[ok, 0], senses[ok, 1])
        )  # fmt: skip
    rows = per_tool(ProgrammeRows.concat(parts), 2)
    centres = {IDS[i]: CANDIDATES[i] for i in chosen}
    centres |= dict(zip(bar.ends, bar.centres_mm, strict=True))
    jac = nominal_jacobian(programme_problem(m14, rows, centres, bar, 0.001, VECTORS))
    assert space.measurements_fixed + space.measurements[chosen].sum() == len(rows.balls)
    np.testing.assert_allclose(
        scaled_spectrum(space.information(chosen)), scaled_spectrum(jac.T @ jac), rtol=1e-9
    )
