"""setup_identifiability: the identifiability of a probing programme from its files."""

from __future__ import annotations

from pathlib import Path

import pytest

from mtmetrology.errors import InputError
from mtmetrology.kinematics import Machine
from mtmetrology.samba import load_artefact, setup_identifiability
from mtmetrology.samba.simulate import load_balls, read_poses, simulate_records

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "samba"


@pytest.fixture(scope="module")
def programme(tmp_path_factory):
    """The example programme as ball-centre readings of the nominal machine."""
    m = Machine.load("five-axis-wcbxfzyst", "13")
    records = simulate_records(
        m,
        None,
        load_balls(EXAMPLES / "balls.yaml").centres(),
        read_poses(EXAMPLES / "poses.csv"),
        load_artefact(EXAMPLES / "artefact.yaml"),
    )
    path = tmp_path_factory.mktemp("prog") / "programme.csv"
    records.write(path)
    return path


def test_the_example_programme_identifies_the_13_parameters(programme):
    result = setup_identifiability(
        "five-axis-wcbxfzyst", programme, model="13", artefact=EXAMPLES / "artefact.yaml"
    )
    d = result.diagnosis
    assert d.full_rank and d.rank == d.n_unknowns
    assert (result.n_params, result.n_scale_bars, result.estimate_tool) == (13, 1, True)
    assert result.to_dict() == {**d.to_dict(), "sigma_um": 1.0}


def test_sigma_scales_the_weights_not_the_rank(programme):
    """Row weights 1/σ: the scaled condition number is invariant; the raw one is not
    unless the scale bar (which keeps its own u) is absent."""
    a = setup_identifiability("five-axis-wcbxfzyst", programme, sigma_um=1.0)
    b = setup_identifiability("five-axis-wcbxfzyst", programme, sigma_um=4.0)
    assert a.diagnosis.rank == b.diagnosis.rank
    assert b.diagnosis.condition_scaled == pytest.approx(a.diagnosis.condition_scaled, rel=1e-9)


def test_without_the_scale_bar_the_scale_is_confounded(programme):
    """Without a scale bar nothing fixes the length scale: E_XX1, E_YY1, E_ZZ1 fall into
    the null space together with the ball layout's size."""
    result = setup_identifiability("five-axis-wcbxfzyst", programme, estimate_tool=False)
    d = result.diagnosis
    assert (d.rank, d.n_unknowns) == (d.n_unknowns - 1, d.n_unknowns)
    (group,) = d.confounded()
    assert {"E_XX1", "E_YY1", "E_ZZ1", "ball 1 x", "ball SB1 x"} <= set(group)
    with_bar = setup_identifiability(
        "five-axis-wcbxfzyst", programme, artefact=EXAMPLES / "artefact.yaml", estimate_tool=False
    )
    assert with_bar.diagnosis.full_rank


@pytest.mark.parametrize("sigma", [0.0, -1.0, float("nan")])
def test_a_non_positive_sigma_is_refused(programme, sigma):
    with pytest.raises(InputError, match=r"^--sigma-um must be a positive number of µm"):
        setup_identifiability("five-axis-wcbxfzyst", programme, sigma_um=sigma)
