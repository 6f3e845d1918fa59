"""ISO 230-2 parameters: every one equals a plain per-element computation written here
(loops, no numpy reductions) to 0.001 µm, for each edition; the vectorised form over many
tests equals one test at a time."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.positioning.parameters import EDITIONS, evaluate
from mtmetrology.positioning.simulate import simulate_many

TOL = 1e-3  # µm


def constructed(seed=11, m=7, n=5):
    """A test with a cubic error, a reversal that changes sign along the axis, and scatter
    that differs per direction (so R_i picks each of its three branches somewhere)."""
    rng = np.random.default_rng(seed)
    x = np.empty((m, n, 2))
    for i in range(m):
        for j in range(n):
            base = 3.0 * i - 0.4 * i**2
            x[i, j, 0] = base + 1.5 - 0.5 * i + rng.normal(0, 0.3 + 0.2 * (i % 3))
            x[i, j, 1] = base - 1.5 + 0.5 * i + rng.normal(0, 0.2 + 0.3 * (i % 2))
    return x


def plain_iso(x, k=2.0):
    """ISO 230-2 written out element by element (k = 2 from 1997 on, 3 in 1988)."""
    m, n = len(x), len(x[0])
    up, dn, su, sd = [], [], [], []
    for i in range(m):
        a = [x[i][j][0] for j in range(n)]
        b = [x[i][j][1] for j in range(n)]
        ma, mb = sum(a) / n, sum(b) / n
        up.append(ma)
        dn.append(mb)
        su.append(math.sqrt(sum((v - ma) ** 2 for v in a) / (n - 1)))
        sd.append(math.sqrt(sum((v - mb) ** 2 for v in b) / (n - 1)))
    bi = [up[i] - dn[i] for i in range(m)]
    mean = [(up[i] + dn[i]) / 2 for i in range(m)]
    ri = [max(k * su[i] + k * sd[i] + abs(bi[i]), 2 * k * su[i], 2 * k * sd[i]) for i in range(m)]
    out = {
        "B": max(abs(v) for v in bi),
        "B_mean": sum(bi) / m,
        "R_up": max(2 * k * v for v in su),
        "R_down": max(2 * k * v for v in sd),
        "R": max(ri),
        "E_up": max(up) - min(up),
        "E_down": max(dn) - min(dn),
        "E": max(up + dn) - min(up + dn),
        "M": max(mean) - min(mean),
        "A_up": max(up[i] + k * su[i] for i in range(m)) - min(up[i] - k * su[i] for i in range(m)),
        "A_down": max(dn[i] + k * sd[i] for i in range(m))
        - min(dn[i] - k * sd[i] for i in range(m)),
    }
    hi = [max(up[i] + k * su[i], dn[i] + k * sd[i]) for i in range(m)]
    lo = [min(up[i] - k * su[i], dn[i] - k * sd[i]) for i in range(m)]
    out["A"] = max(hi) - min(lo)
    per = {"mean_up": up, "mean_down": dn, "mean": mean, "s_up": su, "s_down": sd}
    per |= {"B_i": bi, "R_i": ri}
    return out, per


def plain_vdi(x):
    """VDI/DGQ 3441 as stated in the module, element by element."""
    m, n = len(x), len(x[0])
    mean, psi, ui = [], [], []
    for i in range(m):
        a = [x[i][j][0] for j in range(n)]
        b = [x[i][j][1] for j in range(n)]
        ma, mb = sum(a) / n, sum(b) / n
        va = sum((v - ma) ** 2 for v in a) / (n - 1)
        vb = sum((v - mb) ** 2 for v in b) / (n - 1)
        psi.append(6 * math.sqrt((va + vb) / 2))
        ui.append(abs(ma - mb))
        mean.append((ma + mb) / 2)
    top = [mean[i] + (ui[i] + psi[i]) / 2 for i in range(m)]
    bottom = [mean[i] - (ui[i] + psi[i]) / 2 for i in range(m)]
    return {
        "Ps": max(psi),
        "U": max(ui),
        "U_mean": sum(ui) / m,
        "Pa": max(mean) - min(mean),
        "P": max(top) - min(bottom),
    }


@pytest.mark.parametrize(("edition", "k"), [("2014", 2), ("2006", 2), ("1997", 2), ("1988", 3)])
def test_every_iso_parameter_equals_the_plain_computation(edition, k):
    x = constructed()
    got = evaluate(x, edition)
    want, per = plain_iso(x.tolist(), k)
    for key, value in want.items():
        assert abs(float(got[key]) - value) < TOL, key
    for key, values in per.items():
        assert np.max(np.abs(got[key] - np.array(values))) < TOL, key


def test_1988_and_2014_differ_in_a_and_r_only():
    # the first edition's ±3 s bands against the later ±2 s (AMT): A and R grow by the
    # extra s, E, M and B do not depend on s at all
    x = constructed()
    old, new = evaluate(x, "1988"), evaluate(x, "2014")
    for key in ("A", "A_up", "R", "R_up", "R_down"):
        assert old[key] > new[key] + 0.1, key
    assert old["R_up"] == pytest.approx(1.5 * new["R_up"], rel=1e-12)
    for key in ("E", "E_up", "M", "B", "B_mean"):
        assert old[key] == new[key], key


def test_2006_and_2014_give_the_same_numbers():
    # no public source establishes a change of A or R between these editions (module notes)
    x = constructed()
    old, new = evaluate(x, "2006"), evaluate(x, "2014")
    assert all(np.array_equal(old[key], new[key]) for key in new)


def test_the_constructed_set_exercises_each_branch_of_r_i():
    x = constructed()
    got = evaluate(x)
    r_i, two = got["R_i"], 2 * got["s_up"] + 2 * got["s_down"] + np.abs(got["B_i"])
    assert np.any(np.isclose(r_i, two)) and np.any(np.isclose(r_i, got["R_i_up"]))
    assert np.any(np.isclose(r_i, got["R_i_down"]))


def test_vdi_3441_equals_the_plain_computation():
    x = constructed(seed=5)
    got = evaluate(x, "vdi3441")
    for key, value in plain_vdi(x.tolist()).items():
        assert abs(float(got[key]) - value) < TOL, key


@pytest.mark.parametrize("edition", list(EDITIONS))
def test_many_tests_at_once_equal_one_at_a_time(edition):
    xs = simulate_many(6, 9, 5, seed=2)
    many = evaluate(xs, edition)
    for k in range(6):
        one = evaluate(xs[k], edition)
        for key, value in one.items():
            np.testing.assert_allclose(many[key][k], value, rtol=0, atol=1e-12)


def test_a_pure_reversal_gives_b_and_e_closed_form():
    # x↑ = +1, x↓ = −1 everywhere, no scatter: B = 2, B̄ = 2, E = 2, M = 0, R = 2, A = 2
    x = np.zeros((4, 5, 2))
    x[..., 0], x[..., 1] = 1.0, -1.0
    got = evaluate(x)
    assert (got["B"], got["B_mean"], got["E"], got["M"], got["R"], got["A"]) == (
        2.0, 2.0, 2.0, 0.0, 2.0, 2.0
    )  # fmt: skip
    assert got["E_up"] == 0.0 and got["A_up"] == 0.0


@pytest.mark.parametrize(
    ("shape", "field"),
    [((5, 4, 2), "4 runs"), ((1, 5, 2), "1 target"), ((5, 5, 3), "shape")],
)
def test_bad_shapes_are_refused(shape, field):
    with pytest.raises(InputError) as err:
        evaluate(np.zeros(shape))
    assert field in str(err.value)


def test_unknown_edition_is_refused():
    with pytest.raises(InputError, match="edition"):
        evaluate(np.zeros((3, 5, 2)), "1977")
