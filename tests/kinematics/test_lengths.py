"""Lengths between two positions with u(L) = √(g U_θ gᵀ) (mtmetrology.kinematics.lengths)."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.lengths import pair_lengths, read_reference_lengths

UM = 1e-3


@pytest.fixture(scope="module")
def machine():
    """The XFYZ preset with X's positioning error of Legendre degree 1 and 2 only (travel
    800–1200 mm: u = −1, 0, 1 at X = 800, 1000, 1200; P1 = u, P2 = (3u² − 1)/2)."""
    return Machine.load("three-axis-xfyz").with_parameters(["E_XX1", "E_XX2"])


def test_length_along_x_and_its_u_keep_the_correlation(machine):
    """X from 800 to 1000 mm: L = 200 mm + s·(c1·ΔP1 + c2·ΔP2) with ΔP1 = 1, ΔP2 = −1.5
    and s = ±1 the engine's sign of the positioning error; u²(L) = u1² + 2.25 u2² −
    3 ρ u1 u2 (the two ends share θ̂: with ρ = 0.9 this is far below the uncorrelated
    value)."""
    c = np.array([6.0, 2.0]) * UM
    u1, u2, rho = 2.0 * UM, 1.0 * UM, 0.9
    cov = np.array([[u1**2, rho * u1 * u2], [rho * u1 * u2, u2**2]])
    qa = np.array([[800.0, 300.0, 300.0]])
    qb = np.array([[1000.0, 300.0, 300.0]])
    res = pair_lengths(machine, c, cov, qa, qb)
    # s: the engine's sign of a positioning error at X = 800 mm, where P2 = 1
    s = round((machine.forward(qa, [0.0, UM]) - machine.forward(qa))[0, 0] / UM)
    assert abs(s) == 1
    assert res.nominal[0] == pytest.approx(200.0, abs=1e-12)
    assert res.predicted[0] == pytest.approx(200.0 + s * 3.0 * UM, abs=1e-12)
    expected = np.sqrt(u1**2 + 2.25 * u2**2 - 3 * rho * u1 * u2)
    assert res.u[0] == pytest.approx(expected, rel=1e-9)
    assert res.to_dict()["pairs"][0]["U_um"] == pytest.approx(2 * expected / UM, rel=1e-9)


def test_a_term_equal_at_both_ends_adds_nothing(machine):
    """800 → 1200 mm: P2 = 1 at both ends, so u(L) = 2·u1 however uncertain c2 is."""
    cov = np.diag([(2.0 * UM) ** 2, (50.0 * UM) ** 2])
    res = pair_lengths(machine, np.zeros(2), cov, [[800.0, 300.0, 300.0]], [[1200.0, 300.0, 300.0]])
    assert res.u[0] == pytest.approx(4.0 * UM, rel=1e-12)


def test_reference_error_and_en(machine, tmp_path):
    cov = np.diag([(1.0 * UM) ** 2, (1.0 * UM) ** 2])
    qa, qb = [[800.0, 300.0, 300.0]] * 2, [[1200.0, 300.0, 300.0], [1000.0, 300.0, 300.0]]
    ref = tmp_path / "ref.csv"
    ref.write_text("pair,length_mm,u_um\nq,199.999,1.5\np,400.0,0\n")
    length, u_ref = read_reference_lengths(ref, ["p", "q"])
    res = pair_lengths(machine, np.zeros(2), cov, qa, qb, names=["p", "q"],
                       reference=length, u_reference=u_ref)  # fmt: skip
    doc = res.to_dict()
    assert doc["pairs"][1]["error_um"] == pytest.approx(1.0, abs=1e-9)
    # u(L) of p: 2 µm; of q: √(1 + 2.25) µm; E_n = |e| / (2·√(u² + u_ref²))
    assert doc["pairs"][0]["en"] == 0.0
    assert doc["pairs"][1]["en"] == pytest.approx(1.0 / (2 * np.sqrt(3.25 + 2.25)), rel=1e-9)
    assert doc["within"] == 2
    ref.write_text("pair,length_mm,u_um\np,400.0,0\n")
    with pytest.raises(InputError, match="no reference length for pair 'q'"):
        read_reference_lengths(ref, ["p", "q"])
    with pytest.raises(InputError, match="both ends at one point"):
        pair_lengths(machine, np.zeros(2), cov, qa[:1], qa[:1])
