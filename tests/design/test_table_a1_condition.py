"""Cond_N with every candidate indexation (Alami Mchichi (2018) Tables 5.2, 5.3 and A.1):
why the laboratory balls gave 991 / 809 against the published 588 / 482, and what
normalisation the published figures follow.

Cond_N is the condition number of the column-scaled identification Jacobian (unit-norm
columns of machine parameters, ball centres, scale-bar balls and tool; probing rows
weighted by 1/σ, the bar row by 1/u, σ = u = 1 µm) of the 450 candidate indexations.
Table 5.3 says Cond_N(4 balls) = 482 is Table 5.2's O2 value, i.e. the value at the balls
that step 1 (DETMAX, O2) chose — not the laboratory balls of ``bench/study_design_compare.py``
(991 and 809 for 3 and 4 of them), which nothing optimised for this criterion."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.design.inputs import ScaleBarPlacement, default_indexations
from mtmetrology.design.programme import evaluate_programme, nominal_jacobian, programme_problem
from mtmetrology.design.samba import choose_balls
from mtmetrology.kinematics import Machine

PAIRS = default_indexations()
GRID_X, GRID_Y, STEMS = (-160, -80, 0, 80, 160), (-120, -40, 40, 120), (75, 100, 125, 150, 175)
TABLE_A1_O2 = {1: 44.6, 2: 59.5, 3: 73.0, 4: 84.3}  # 13 parameters


def _grid():
    """The seed-004 step-1 candidates: 5 × 4 pallet positions × 5 stems (100 balls)."""
    c = np.array([(x, y, h) for h in STEMS for y in GRID_Y for x in GRID_X], dtype=float)
    return [f"x{x:g}y{y:g}h{h:g}" for x, y, h in c], c


def _cond(value: float) -> float:
    return 1.0 / value  # O2 = σ_min/σ_max of the column-scaled Jacobian


@pytest.fixture(scope="module")
def chosen13():
    m = Machine.load("five-axis-wcbxfzyst", "13")
    ids, c = _grid()
    return m, {n: choose_balls(m, ids, c, n, PAIRS, starts=1, seed=1) for n in (1, 2, 3, 4)}


def test_84_parameter_cond_n_at_the_step1_balls_is_the_published_size():
    """Step 1 (O2, 3 starts) on the 100 candidates: Cond_N 471 for 4 balls (Table 5.2/5.3:
    482, −2.4 %) and 525 for 3 (Table 5.2: 565, Table 5.3: 588; −7 / −11 %), where the
    laboratory balls give 809 and 991: the normalisation is the one implemented, the
    discrepancy was the ball set. (One DETMAX start lands anywhere in 487–616: the
    published values lie in the spread of DETMAX's local optima.)"""
    m = Machine.load("five-axis-wcbxfzyst", "84")
    ids, c = _grid()
    four = _cond(choose_balls(m, ids, c, 4, PAIRS, starts=3, seed=1)[2].best.value)
    three = _cond(choose_balls(m, ids, c, 3, PAIRS, starts=3, seed=1)[2].best.value)
    assert four == pytest.approx(482, rel=0.05)
    assert three == pytest.approx(565, rel=0.10) and three == pytest.approx(588, rel=0.15)
    assert three > four  # more balls condition better for the 84-parameter model


def test_13_parameter_cond_n_follows_table_a1_up_to_one_common_factor(chosen13):
    """At the step-1 balls: 32.8, 44.1, 53.4, 62.1 against 44.6, 59.5, 73.0, 84.3: the
    ratio is the same for 1–4 balls (0.73–0.74, spread < 0.02), so the trend and the
    proportions are the source's and one factor common to all designs differs."""
    _, chosen = chosen13
    conds = {n: _cond(res.best.value) for n, (_, _, res) in chosen.items()}
    ratio = np.array([conds[n] / TABLE_A1_O2[n] for n in (1, 2, 3, 4)])
    assert np.ptp(ratio) < 0.02 and np.all((ratio > 0.70) & (ratio < 0.78)), ratio


def test_the_common_factor_is_the_weight_of_the_scale_bar_row(chosen13):
    """The factor moves with the weight of the bar row against the probing rows (neither
    the source's σ for the design nor its weighting is stated): with the bar's u at 1.8 σ
    every Table A.1 value is reproduced within 7 % (1 and 4 balls here; 2 and 3: −1.4 %,
    −5.7 %). Recorded, not adopted: it is one number fitted to four."""
    m, chosen = chosen13
    bar = ScaleBarPlacement(u_mm=0.0018)
    for n in (1, 4):
        ids, centres, _ = chosen[n]
        cond = evaluate_programme(m, ids, centres, PAIRS, bar=bar).report.condition_scaled
        assert cond == pytest.approx(TABLE_A1_O2[n], rel=0.07), n


def test_the_parameters_only_reading_is_rejected(chosen13):
    """The "reduced" Jacobian read as the machine-parameter columns alone (ball, bar and
    tool columns dropped) gives 12–17 for the 13-parameter designs of 1 and 4 balls,
    three to five times below Table A.1 (44.6 and 84.3): not the source's figure."""
    m, chosen = chosen13
    bar = ScaleBarPlacement()
    for n in (1, 4):
        ids, centres, _ = chosen[n]
        prog = evaluate_programme(m, ids, centres, PAIRS)
        where = dict(zip(ids, centres, strict=True))
        where |= dict(zip(bar.ends, bar.centres_mm, strict=True))
        j = nominal_jacobian(programme_problem(m, prog.rows, where, bar, 0.001))[:, : m.n_params]
        s = np.linalg.svd(j / np.linalg.norm(j, axis=0), compute_uv=False)
        assert s[0] / s[-1] < 0.4 * TABLE_A1_O2[n], n
