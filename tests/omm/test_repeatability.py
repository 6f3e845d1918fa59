"""Tests of mtmetrology.omm.repeatability: per-target statistics of replicated probing
(the pose models are tested in test_repeatability_model.py)."""

from __future__ import annotations

import numpy as np
import pytest
from test_repeatability_model import simulated_records

from mtmetrology.errors import InputError
from mtmetrology.omm.repeatability import (
    lateral_deviation_threshold,
    normal_tangential,
    sphere_normal,
    target_statistics,
)
from mtmetrology.units import to_internal

UM = to_internal(1.0, "µm")


def test_appendix_a_projection_example():
    """Sepahi Boroujeni (2021), App. A: N = 15.2211 mm, T ≈ 0.0009 mm."""
    n = sphere_normal(np.radians(18.0), np.radians(144.0))
    big_n, t = normal_tangential([78.9655, 76.1950, -64.4430], [76.2, 80.0, -78.9190], n)
    assert round(float(big_n), 4) == 15.2211
    assert abs(float(t) - 0.0009) < 0.00005


def test_lateral_deviation_threshold_is_125_3_um():
    """Sepahi Boroujeni (2021), §4: R = 15.7 mm, d = 0.5 µm → b′ = 125.3 µm."""
    b = lateral_deviation_threshold(15.7, to_internal(0.5, "µm"))
    assert round(b / UM, 1) == 125.3
    with pytest.raises(InputError, match="radius > 0"):
        lateral_deviation_threshold(-1.0, 0.0005)


def test_statistics_discard_the_first_touch_and_order_by_time():
    rec = simulated_records(3, 6, seed=1)
    perm = np.random.default_rng(0).permutation(len(rec["time"]))
    shuffled = {
        k: (np.asarray(v)[perm] if k != "target" else [v[i] for i in perm]) for k, v in rec.items()
    }
    st = target_statistics(**shuffled)
    ref = np.asarray(rec["readings"]).reshape(3, 6, 3)[:, 1:]
    order = [st.targets.index(f"t{t}") for t in range(3)]
    assert np.allclose(st.std[order, :3], ref.std(axis=1, ddof=1), rtol=1e-12)
    assert np.allclose(st.cov[order, 0], [np.cov(r[:, 0], r[:, 1])[0, 1] for r in ref])
    assert np.all(st.n_touches == 5)


def test_normal_and_tangential_projection_of_pure_normal_scatter():
    """Readings scattered only along n̂: σ_N equals the scatter, T stays 0."""
    n = sphere_normal(np.radians(30.0), np.radians(200.0))
    steps = np.array([0.0, 1.0, -1.0, 2.0, 0.5]) * UM
    readings = 10.0 + steps[:, None] * n
    st = target_statistics(
        ["a"] * 5,
        np.zeros((5, 7)),
        readings,
        np.tile(n, (5, 1)),
        np.arange(5.0),
        discard_first=False,
    )
    assert st.std[0, 3] == pytest.approx(np.std(steps, ddof=1), rel=1e-9)
    assert st.std[0, 4] < 1e-9  # 1 pm: rounding of √(‖CP‖² − N²) only


def test_zero_variance_coordinates_are_flagged():
    readings = np.array(
        [[1.0, 2.0, 3.0], [1.0, 2.0005, 3.0], [1.0, 2.0, 3.0005], [1.0, 2.0005, 3.0]]
    )
    n = np.tile([1.0, 0.0, 0.0], (4, 1))
    st = target_statistics(["a"] * 4, np.zeros((4, 7)), readings, n, np.arange(4.0))
    assert st.zero_variance[0].tolist() == [True, False, False]


def test_too_few_touches_and_changing_pose_are_refused():
    n = np.tile([1.0, 0.0, 0.0], (3, 1))
    with pytest.raises(InputError, match="usable touches"):
        target_statistics(["a"] * 3, np.zeros((3, 7)), np.zeros((3, 3)), n, np.arange(3.0))
    f = np.zeros((4, 7))
    f[2, 4] = 1.0
    with pytest.raises(InputError, match="pose factors change"):
        target_statistics(["a"] * 4, f, np.zeros((4, 3)), np.tile(n[:1], (4, 1)), np.arange(4.0))
