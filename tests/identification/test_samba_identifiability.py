"""Rank and confounding of SAMBA set-ups: the claims of digests 000/004 as re-checked in
identifiability-check.md (Q1, Q2). Jacobians are evaluated at the nominal point."""

import numpy as np
import pytest

from mtmetrology.identification import (
    BallCentreProblem,
    ScaleBar,
    analyse_identifiability,
    senses_from_sequence,
)
from mtmetrology.kinematics import Machine
from mtmetrology.samba import probing_sequence

GRID_PAIRS = [(b, c) for b in (-90, -45, 0, 45, 90) for c in range(0, 360, 60)]
# probing noise and scale-bar u of the identifiability check (1 µm each)
SIGMA = 0.001


def report(
    machine,
    setup,
    pairs,
    *,
    tool=True,
    bar=True,
    spindle=(90, 180, 270),
    bar_pairs=((0, 0), (0, 90)),
    backlash=False,
):
    ids, q = probing_sequence(machine, setup, pairs, spindle_deg=spindle, bar_pairs_deg=bar_pairs)
    bars = [ScaleBar(("SB1", "SB2"), setup.scale_bar_length, u=SIGMA)] if bar else []
    problem = BallCentreProblem(
        machine,
        q,
        ids,
        scale_bars=bars,
        estimate_tool=tool,
        sigma=SIGMA,
        senses=senses_from_sequence(q) if backlash else None,
    )
    _, jac = problem.evaluate(problem.initial())
    return analyse_identifiability(jac, problem.names, report_names=machine.parameter_names)


def nonlinear_pairs(seed):
    """17 (B, C) pairs off any line, B and C on a 15° grid, including (0, 0)."""
    rng = np.random.default_rng(seed)
    cands = [(b, c) for b in range(-90, 91, 15) for c in range(0, 360, 15) if (b, c) != (0, 0)]
    pick = rng.choice(len(cands), 16, replace=False)
    return sorted([(0, 0)] + [cands[i] for i in pick])


def test_13_parameter_set_is_full_rank(samba_setup):
    """Q1: 13 parameters + 6 balls x 3 + tool = 34 unknowns, rank 34, cond ≈ 25."""
    m = Machine.load("five-axis-wcbxfzyst", "13")
    rep = report(m, samba_setup, GRID_PAIRS)
    assert rep.n_unknowns == 34 and rep.full_rank
    assert 20 < rep.condition_scaled < 30  # identifiability-check: 25.3
    rep = report(m, samba_setup, GRID_PAIRS, tool=False)
    assert rep.n_unknowns == 31 and rep.full_rank


def test_adding_E_Y0C_confounds_it_with_the_spindle_offset(samba_setup):
    """Digest 000 §3.2.3: E_Y0C is indistinguishable from E_Y0S."""
    m = Machine.load("five-axis-wcbxfzyst")
    m = m.with_parameters([*m.parameter_names, "E_Y0C"])
    rep = report(m, samba_setup, GRID_PAIRS)
    assert rep.rank == rep.n_unknowns - 1
    assert [set(g) for g in rep.confounded()] == [{"E_Y0C", "E_Y0S"}]
    assert rep.message == "rank 34 of 35: E_Y0S ~ E_Y0C"


def test_adding_E_A0Z_confounds_it_with_the_B_squareness(samba_setup):
    """Identifiability-check Q1: E_A0Z's partner is E_A(0Z)B (a rigid rotation about X of
    the tool branch equals a tilt of B). Here Z turns about its reference point 150 mm from
    the stylus centre, so the spindle Y offset takes up the translation part."""
    m = Machine.load("five-axis-wcbxfzyst")
    m = m.with_parameters([*m.parameter_names, "E_A0Z"])
    rep = report(m, samba_setup, GRID_PAIRS)
    assert rep.rank == rep.n_unknowns - 1
    assert {"E_A0Z", "E_A0B"} <= set(rep.confounded()[0])


def test_without_spindle_indexing_tool_and_spindle_offsets_are_confounded(samba_setup):
    m = Machine.load("five-axis-wcbxfzyst")
    rep = report(m, samba_setup, GRID_PAIRS, spindle=())
    assert rep.rank == rep.n_unknowns - 2
    groups = [set(g) for g in rep.confounded()]
    assert {"E_X0S", "tool x"} in groups and {"E_Y0S", "tool y"} in groups


def test_without_the_scale_bar_the_scale_gains_are_not_identifiable(samba_setup):
    m = Machine.load("five-axis-wcbxfzyst")
    rep = report(m, samba_setup, GRID_PAIRS, bar=False)
    assert rep.rank == rep.n_unknowns - 1
    assert {"E_XX1", "E_YY1", "E_ZZ1"} <= set(rep.confounded()[0])


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_84_coefficients_full_rank_with_17_nonlinear_pairs(samba_setup, seed):
    """Q2: 84 + 6 x 3 + 3 = 105 unknowns, rank 105 (check: 30/30 random sets, cond 692-2010)."""
    m = Machine.load("five-axis-wcbxfzyst", "84")
    rep = report(m, samba_setup, nonlinear_pairs(seed), backlash=True)
    assert rep.n_unknowns == 105 and rep.full_rank
    assert 500 < rep.condition_scaled < 3000


def test_linear_pairing_c_equals_3b_confounds_ZC_with_ZB_and_CB_with_CC(samba_setup):
    """Seed 004 Table 4.4 and Q2: with every measurement on the line c = 3b (scale bar only
    at b = c = 0) the rank is 99 of 105 and the six null directions pair E_ZC_k with E_ZB_k
    and E_CB_k with E_CC_k, k = 1, 2, 3."""
    m = Machine.load("five-axis-wcbxfzyst", "84")
    line = [(b, 3 * b) for b in range(-90, 91, 15)]
    rep = report(m, samba_setup, line, bar_pairs=((0, 0),), backlash=True)
    assert rep.rank == 99
    pairs = {frozenset(g) for g in rep.confounded()}
    expected = {frozenset({f"E_ZC{k}", f"E_ZB{k}"}) for k in (1, 2, 3)}
    expected |= {frozenset({f"E_CB{k}", f"E_CC{k}"}) for k in (1, 2, 3)}
    assert pairs == expected


@pytest.mark.parametrize(
    ("extra", "partner"),
    [
        ("E_AY1", "E_YY1"),
        ("E_AY2", "E_YY2"),
        ("E_BY2", "E_XY2"),
        ("E_BY1", "E_CZ0"),
        ("E_BZ1", "E_XZ1"),
        ("E_BZ3", "E_XZ3"),
    ],
)
def test_single_stylus_confounds_of_seed004_table_4_4(samba_setup, extra, partner):
    m = Machine.load("five-axis-wcbxfzyst", "84")
    m = m.with_parameters([*m.parameter_names, extra])
    rep = report(m, samba_setup, nonlinear_pairs(0), backlash=True)
    assert rep.rank == rep.n_unknowns - 1
    assert {extra, partner} <= set(rep.confounded()[0])


def test_spindle_roll_E_CY_is_not_observable(samba_setup):
    """Seed 004 Table 4.4: the stylus tip lies on the tool-frame Z axis."""
    m = Machine.load("five-axis-wcbxfzyst", "84")
    m = m.with_parameters([*m.parameter_names, "E_CY1"])
    rep = report(m, samba_setup, nonlinear_pairs(0), backlash=True)
    assert str(rep.null_directions[0]) == "E_CY1 (not observable)"


def test_unidirectional_approach_loses_the_backlash(samba_setup):
    m = Machine.load("five-axis-wcbxfzyst", "84")
    ids, q = probing_sequence(m, samba_setup, nonlinear_pairs(0))
    problem = BallCentreProblem(
        m,
        q,
        ids,
        scale_bars=[ScaleBar(("SB1", "SB2"), samba_setup.scale_bar_length, u=SIGMA)],
        estimate_tool=True,
        senses=np.ones_like(q),
        sigma=SIGMA,
    )
    rep = analyse_identifiability(problem.evaluate(problem.initial())[1], problem.names)
    assert rep.rank == rep.n_unknowns - 2
    assert any({"E_BBb", "E_BB0"} <= set(g) for g in rep.confounded())
