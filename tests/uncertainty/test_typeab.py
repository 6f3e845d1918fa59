"""Tests for mtmetrology.uncertainty.typeab (JCGM 100 §4.2–4.3)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mtmetrology.uncertainty.typeab import (
    arcsine_u,
    expanded_to_u,
    pooled_std,
    rectangular_u,
    resolution_u,
    spec_linear,
    spec_quadrature,
    triangular_u,
    type_a,
    type_a_pooled,
)


def test_type_a_mean_std_and_standard_uncertainty_of_mean():
    q = [10.0, 12.0, 11.0, 13.0, 9.0]
    r = type_a(q)
    assert r.mean == pytest.approx(11.0)
    assert r.std == pytest.approx(math.sqrt(10 / 4))
    assert r.u == pytest.approx(math.sqrt(10 / 4) / math.sqrt(5))
    assert (r.dof, r.n) == (4.0, 5)


def test_pooled_std_and_type_a_with_pooled_estimate():
    """JCGM 100 4.2.4: s_p² = Σ(n_i−1)s_i²/Σ(n_i−1)."""
    g1, g2 = [1.0, 2.0, 3.0], [5.0, 7.0]
    p = pooled_std([g1, g2])
    assert p.dof == 3.0
    assert p.std == pytest.approx(math.sqrt((2 * 1.0 + 1 * 2.0) / 3))
    r = type_a_pooled([4.0, 6.0, 5.0, 5.0], p)
    assert r.u == pytest.approx(p.std / 2) and r.dof == 3.0 and r.mean == 5.0


def test_type_b_conversions():
    assert expanded_to_u(0.52, k=2) == pytest.approx(0.26)
    # 95 % with ν = ∞ → k = 1.95996
    assert expanded_to_u(1.96, p=0.95) == pytest.approx(1.0, rel=1e-4)
    # 95 % with ν = 10 → t = 2.228
    assert expanded_to_u(2.228, p=0.95, dof=10) == pytest.approx(1.0, rel=1e-3)
    assert rectangular_u(math.sqrt(3)) == pytest.approx(1.0)
    assert triangular_u(math.sqrt(6)) == pytest.approx(1.0)
    assert arcsine_u(math.sqrt(2)) == pytest.approx(1.0)
    # Resolution 0.1 µm → 0.0289 µm (JCGM 100 F.2.2.1).
    assert resolution_u(0.1) == pytest.approx(0.1 / math.sqrt(12))


def test_length_dependent_specifications():
    """MPE = 0.6 µm + L/600 (L in mm) and U = sqrt(0.52² + (1.4e-3·L)²) µm."""
    np.testing.assert_allclose(spec_linear(0.6, 1 / 600, [0.0, 300.0, 600.0]), [0.6, 1.1, 1.6])
    assert spec_quadrature(0.52, 1.4e-3, 0.0) == pytest.approx(0.52)
    assert spec_quadrature(0.52, 1.4e-3, 500.0) == pytest.approx(math.hypot(0.52, 0.7))
    # MPE to standard uncertainty (rectangular, ±MPE).
    assert rectangular_u(float(spec_linear(0.6, 1 / 600, 300.0))) == pytest.approx(
        1.1 / math.sqrt(3)
    )


def test_bad_inputs():
    with pytest.raises(ValueError, match="at least 2 indications"):
        type_a([1.0])
    with pytest.raises(ValueError, match="contains 1 NaN"):
        type_a([1.0, float("nan"), 2.0])
    with pytest.raises(ValueError, match="exactly one of k or p"):
        expanded_to_u(1.0)
    with pytest.raises(ValueError, match="a must be finite and >= 0"):
        rectangular_u(-1.0)
    with pytest.raises(ValueError, match="k must be > 0"):
        expanded_to_u(1.0, k=0)
