"""Tests for probing and axis hysteresis (Sepahi Boroujeni (2021), eqs. 4-3 and 4-4; T21)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats as sps

from mtmetrology.errors import InputError
from mtmetrology.omm.hysteresis import hysteresis_errors, radial_projection
from mtmetrology.units import from_internal, to_internal

UM = to_internal(1.0, "µm")
DEG = to_internal(1.0, "deg")


def _replicates(mean, offsets):
    """Replicates with an exact mean: ``mean`` plus zero-sum ``offsets``."""
    offsets = np.asarray(offsets, float)
    return mean + (offsets - offsets.mean())


def test_u_of_h_matches_the_closed_form():
    """H = 2 − 5 = −3 µm; u² = s_H²/n_H + s²/n = 1/3 + (20/3)/4 = 2 µm²; ν_eff = 216/53."""
    r = np.array([1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 8.0]) * UM
    res = hysteresis_errors(np.zeros(7), r, [True] * 3 + [False] * 4)
    assert res.hysteresis[0] == pytest.approx(-3.0 * UM, rel=1e-12)
    assert res.standard_uncertainty[0] == pytest.approx(np.sqrt(2.0) * UM, rel=1e-12)
    # Welch–Satterthwaite: ν = u⁴ / ((1/3)²/2 + (5/3)²/3) = 4 / (1/18 + 25/27) = 216/53.
    assert res.dof[0] == pytest.approx(216 / 53, rel=1e-12)
    assert res.coverage_factor[0] == pytest.approx(sps.t.ppf(0.975, 216 / 53), rel=1e-12)
    assert (res.n_affected[0], res.n_reference[0]) == (3, 4)


def test_summary_over_indexations():
    """Two indexations: H = −3 and +2 µm, u² = 2 and 1/3 µm² (3 and 4 replicates)."""
    psi = np.repeat([0.0, 30.0], 7) * DEG
    cond = [True] * 3 + [False] * 4 + [True] * 3 + [False] * 4
    r = np.r_[[1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 8.0], [2, 3, 4, 1, 1, 1, 1]] * UM
    res = hysteresis_errors(psi, r, cond)
    assert from_internal(res.hysteresis, "µm") == pytest.approx([-3.0, 2.0])
    u2 = np.array([2.0, 1.0 / 3.0])
    assert from_internal(res.standard_uncertainty, "µm") ** 2 == pytest.approx(u2)
    assert res.mean == pytest.approx(-0.5 * UM)
    assert res.mean_abs == pytest.approx(2.5 * UM)
    assert res.mean_u == pytest.approx(np.sqrt(u2.sum()) / 2 * UM)
    assert res.rms_u == pytest.approx(np.sqrt(u2.mean()) * UM)
    # The reference replicates of ψ = 30° do not scatter: ν_eff is that of r̄_H alone.
    assert res.dof[1] == pytest.approx(2.0)
    doc = res.to_dict()
    assert doc["kind"] == "hysteresis-result" and doc["version"] == 1
    assert [o["name"] for o in doc["outputs"]] == ["H_0", "H_30"]
    low, high = doc["outputs"][0]["interval"]
    assert low == pytest.approx(-3.0 - doc["outputs"][0]["U"]) and high > low


def test_thesis_worked_example_gives_plus_0_2_um_not_the_reported_minus_0_17():
    """ψ = 60°, r̄_H = 28.7821 mm, r̄ = 28.7819 mm (Sepahi Boroujeni (2021), App. A).

    Eq. 4-3 gives H₆₀ = r̄_H − r̄ = +0.2 µm. The thesis prints −0.17 µm, which lies
    outside the rounding interval [0.1, 0.3] µm of two means printed to 0.1 µm: a known
    inconsistency of the source (sign or rounding). The axis example, 28.7623 − 28.7618 mm
    = 0.5 µm against a printed 0.46 µm, is consistent within that rounding.
    """
    offsets = np.random.default_rng(60).normal(0, 0.4, 24) * UM
    r = np.r_[_replicates(28.7821, offsets), _replicates(28.7819, offsets[::-1])]
    res = hysteresis_errors(np.full(48, 60.0 * DEG), r, [True] * 24 + [False] * 24)
    h = from_internal(res.hysteresis[0], "µm")
    assert h == pytest.approx(0.2, abs=1e-6)
    rounding = 0.1  # µm: each mean is printed to 0.05 µm either way
    assert not (h - rounding <= -0.17 <= h + rounding)
    axis = hysteresis_errors(
        np.zeros(48),
        np.r_[_replicates(28.7623, offsets), _replicates(28.7618, offsets)],
        [True] * 24 + [False] * 24,
        kind="axis",
    )
    h_axis = from_internal(axis.hysteresis[0], "µm")
    assert h_axis == pytest.approx(0.5, abs=1e-6) and abs(h_axis - 0.46) <= rounding
    assert axis.to_dict()["definition"] == "H = mean r (+) - mean r (-)"


def test_coverage_of_the_95_percent_intervals():
    """2000 simulated indexations, 24 replicates per condition, σ_H = 0.5 µm, σ = 0.8 µm.

    The fraction of intervals H_ψ ± k u(H_ψ) (t with Welch–Satterthwaite ν) holding the
    true H = −0.11 µm is binomial(2000, 0.95): it must lie in the two-sided 99 % region.
    """
    rng = np.random.default_rng(21)
    m, n, h_true = 2000, 24, -0.11 * UM
    with_h = 28.78 + h_true + rng.normal(0, 0.5 * UM, (m, n))
    without = 28.78 + rng.normal(0, 0.8 * UM, (m, n))
    psi = np.repeat(np.arange(m) * 0.1 * DEG, 2 * n)
    r = np.hstack([with_h, without]).ravel()
    cond = np.tile(np.r_[np.ones(n, bool), np.zeros(n, bool)], m)
    res = hysteresis_errors(psi, r, cond)
    inside = np.abs(res.hysteresis - h_true) <= res.coverage_factor * res.standard_uncertainty
    lo, hi = sps.binom.ppf([0.005, 0.995], m, 0.95)
    assert lo <= inside.sum() <= hi
    assert np.all((res.dof > n - 1) & (res.dof < 2 * n - 2))  # Welch between the two


def test_radial_projection_of_ring_readings():
    psi = np.array([0.0, 90.0, 225.0]) * DEG
    x = 28.78 * np.cos(psi)
    y = 28.78 * np.sin(psi)
    assert radial_projection(x, y, psi) == pytest.approx(28.78, rel=1e-15)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"affected": [True, False, False]}, "'hysteresis'"),
        ({"kind": "backlash"}, "kind"),
        ({"p": 1.0}, "p:"),
        ({"radius": [1.0, np.nan, 2.0]}, "finite"),
        ({"radius": [1.0, 2.0]}, "one length"),
    ],
)
def test_bad_input_is_refused(kwargs, field):
    args = {"psi": np.zeros(3), "radius": [1.0, 2.0, 3.0], "affected": [True, True, False]}
    args.update(kwargs)
    with pytest.raises(InputError, match=field):
        hysteresis_errors(**args)
