"""Tests for mtmetrology.omm.pooling (Sepahi Boroujeni (2021), §6.5, pooling test)."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.fitting.features import SphereDiameter, Sphericity
from mtmetrology.kinematics.machine import Machine
from mtmetrology.omm.pooling import pooling_experiment
from mtmetrology.omm.reference import thermal_reference_value
from mtmetrology.omm.repeatability import sphere_normal
from mtmetrology.units import to_internal

MACHINE = Machine.load("five-axis-wcbxfzyst")
UM = to_internal(1.0, "µm")
# Table A.6-2: B, C (degrees) of the 10 sphere point sets.
POSES = np.radians(
    [
        [55, -35, -40, -24, -11, 19, 32, -5, 7, 25],
        [-22, -299, -171, -73, -9, -207, -254, -305, -132, -96],
    ]
).T
DIAMETER = 19.05  # mm, the calibrated precision sphere of §6.4
TIP = 2 * MACHINE.tip_radius
N_POINTS = 25
COV_E = np.array([[4.5, -1.7, 0.5], [-1.7, 6.6, 0.7], [0.5, 0.7, 5.8]]) * 1e-5  # eq. 6-15, fixed
V = np.diag([(0.5 * UM) ** 2] * 3 + [0.0] * 3)  # 0.5 µm repeatability per linear axis
FEATURES = [SphereDiameter(tip_diameter=TIP), Sphericity()]
REFERENCES = [(DIAMETER, 0.25 * UM), (0.0, 0.0)]  # a perfect virtual sphere


def _point_sets(offset_um: float, seed: int = 0):
    """Ten 25-point sets on the sphere at the Table A.6-2 poses of a virtual machine.

    Calibration δ (~10 µm, µrad, µm/m), the day's true parameters one draw of N(δ, Σ) with
    Σ = (1 unit)², 0.5 µm repeatability, and an unmodelled rigid offset per pose of
    ``offset_um`` µm per axis (a hysteresis or lobing bias constant over one set). The
    random numbers do not depend on ``offset_um``: the sets differ only by the offsets.
    """
    rng = np.random.default_rng(seed)
    delta = rng.normal(size=13) * MACHINE.parameter_scales * 10
    sigma = np.diag(MACHINE.parameter_scales**2)
    truth = rng.multivariate_normal(delta, sigma)
    radius = (DIAMETER + TIP) / 2  # stylus-centre sphere
    sets = []
    for b, c in POSES:
        normals = sphere_normal(
            rng.uniform(0.0, 1.4, N_POINTS), rng.uniform(0, 2 * np.pi, N_POINTS)
        )
        offset = rng.normal(size=3) * offset_um * UM
        start = np.zeros((N_POINTS, 6))
        start[:, 3:5] = b, c
        readings = MACHINE.inverse([0.0, 0.0, 100.0] + radius * normals - offset, start, truth)
        readings[:, :3] += rng.normal(0.0, 0.5 * UM, (N_POINTS, 3))
        sets.append(readings)
    return sets, delta, sigma


def _experiment(offset_um, k_values=(1, 2, 3, 5), draws=40, seed=0):
    sets, delta, sigma = _point_sets(offset_um)
    return pooling_experiment(
        MACHINE,
        sets,
        delta,
        sigma,
        FEATURES,
        REFERENCES,
        reading_covariance=V,
        unexplained_covariance=COV_E,
        k_values=k_values,
        draws=draws,
        seed=seed,
    )


@pytest.fixture(scope="module")
def clean():
    return _experiment(0.0)


@pytest.fixture(scope="module")
def biased():
    return _experiment(15.0)


def test_without_unmodelled_error_diameter_and_sphericity_intervals_hold(clean):
    """The truth's errors (0.5 µm repeatability, the day's parameter change of ~1 unit) are
    far inside the budget's U (≈ 18–20 µm, dominated by E), so every k covers."""
    assert clean.output_names == ("sphere_diameter", "sphericity")
    assert np.all(clean.coverage >= 0.95)
    assert np.all(np.abs(clean.mean_value[:, 0] - DIAMETER) < 2 * UM)


def test_a_per_pose_offset_leaves_one_set_unchanged(clean, biased):
    """A rigid offset does not change an LS diameter or sphericity: k = 1 draws (a whole
    set each) give the same values with and without it (to 1 nm; the compensation is
    translation invariant only to first order, observed 4e-14 mm)."""
    assert np.allclose(biased.values[0], clean.values[0], rtol=0, atol=1e-6)
    assert np.array_equal(biased.coverage[0], [1.0, 1.0])


def test_a_per_pose_offset_collapses_sphericity_coverage_from_k_2(biased):
    """15 µm per axis per pose (|b_i − b_j| ≈ 37 µm on average, against U ≈ 20 µm): the
    sphericity of a pooled draw is of the order of the offset difference, so its coverage
    falls at k = 2 and vanishes from k = 3 (the thesis: 100 % → 9 % → 0). The diameter
    sees the offsets only through their scatter over 25 points (≈ 0.25 |b_i − b_j|), so
    its coverage stays high at k = 2. Thresholds: over seeds 0–9 of this set-up the
    sphericity coverage was ≤ 0.35 at k = 2 and ≤ 0.10 beyond, the diameter's ≥ 0.75 at
    k = 2 (40 draws: binomial s.e. ≤ 0.08)."""
    diameter, sphericity = biased.coverage[:, 0], biased.coverage[:, 1]
    assert sphericity[1] <= 0.5 and np.all(sphericity[2:] <= 0.15)
    assert diameter[1] >= 0.7
    assert np.all(diameter[1:3] - sphericity[1:3] >= 0.4)
    # the pooled sphericity grows with k (more poses, larger spread of offsets)
    assert np.all(np.diff(biased.mean_value[:, 1]) > 0)


def test_each_k_has_its_own_stream_and_k_1_draws_are_whole_sets():
    sets, delta, sigma = _point_sets(0.0)
    args = (MACHINE, sets[:3], delta, sigma, FEATURES, REFERENCES)
    kw = dict(reading_covariance=V, unexplained_covariance=COV_E, draws=6, seed=5)
    both = pooling_experiment(*args, k_values=[1, 3], **kw)
    alone = pooling_experiment(*args, k_values=[3], **kw)
    assert np.array_equal(both.values[1], alone.values[0])
    compensated = [MACHINE.forward(s, delta) for s in sets[:3]]
    per_set = [FEATURES[0].value(q) for q in compensated]
    for value in both.values[0, :, 0]:
        assert min(abs(value - d) for d in per_set) < 1e-9
    # a ReferenceValue (thermal correction, eq. 6-17) serves as well as (y_cal, u_cal)
    ref = thermal_reference_value(
        DIAMETER,
        0.25 * UM,
        expansion_coefficient=0.0,
        expansion_coefficient_uncertainty=0.0,
        temperature_difference=0.0,
        temperature_difference_uncertainty=0.0,
    )
    with_ref = pooling_experiment(*args[:5], [ref, REFERENCES[1]], k_values=[1, 3], **kw)
    assert np.array_equal(with_ref.coverage, both.coverage)
    doc = both.to_dict()
    assert doc["kind"] == "omm-pooling-test" and doc["draws"] == 6
    assert [e["k"] for e in doc["outputs"][1]["per_k"]] == [1, 3]


@pytest.mark.parametrize(
    ("kw", "named"),
    [
        ({"k_values": [0]}, r"k_values: each must be an integer in 1 … 3, got \[0\]"),
        ({"k_values": [4]}, r"k_values: each must be an integer in 1 … 3, got \[4\]"),
        ({"points_per_draw": 26}, "points_per_draw = 26, but 1 set"),
        ({"references": [(DIAMETER, 0.0)]}, "references: 1 given for 2 outputs"),
        ({"reading_covariance": np.eye(3)}, r"reading_covariance: .* got shape \(3, 3\)"),
        ({"draws": 0}, "draws: must be a positive integer, got 0"),
    ],
    ids=["k0", "k-too-large", "too-few-points", "references", "covariance-shape", "draws"],
)
def test_bad_arguments_are_refused_naming_the_argument(kw, named):
    sets, delta, sigma = _point_sets(0.0)
    args = dict(references=REFERENCES, draws=2, seed=1, k_values=[1])
    args.update(kw)
    with pytest.raises(InputError, match=f"^{named}"):
        pooling_experiment(MACHINE, sets[:3], delta, sigma, FEATURES, **args)


def _equator_set(seed: int = 3):
    """25 points on the equator of the sphere (a great circle, 0.5 µm noise): one pose
    whose least-squares sphere cannot be determined — a deliberately failing fit."""
    rng = np.random.default_rng(seed)
    _, delta, _ = _point_sets(0.0)
    radius = (DIAMETER + TIP) / 2
    normals = sphere_normal(np.full(N_POINTS, np.pi / 2), rng.uniform(0, 2 * np.pi, N_POINTS))
    start = np.zeros((N_POINTS, 6))
    start[:, 3:5] = POSES[0]
    readings = MACHINE.inverse([0.0, 0.0, 100.0] + radius * normals, start, delta)
    readings[:, :3] += rng.normal(0.0, 0.5 * UM, (N_POINTS, 3))
    return readings


def test_a_failing_fit_is_excluded_counted_and_named_and_u_stays():
    """Four good sets and one on a great circle: every draw of the bad set alone (k = 1)
    fails (the least-squares sphere does not converge), is named and excluded; the mean U
    of k = 1 is within 10 % of the four good sets' own. Averaged in, the failed draws made
    it 5.2 mm against 17 µm (measured with the exclusion switched off)."""
    sets, delta, sigma = _point_sets(0.0)
    good = sets[:4]
    kw = dict(reading_covariance=V, unexplained_covariance=COV_E, k_values=[1, 2], draws=40)
    names = ["a.csv", "b.csv", "c.csv", "d.csv", "equator.csv"]
    calls = []
    with_bad = pooling_experiment(
        MACHINE, [*good, _equator_set()], delta, sigma, FEATURES, REFERENCES, seed=2,
        set_names=names, progress=lambda done, total: calls.append((done, total)), **kw,
    )  # fmt: skip
    without = pooling_experiment(MACHINE, good, delta, sigma, FEATURES, REFERENCES, seed=2, **kw)
    assert without.failed == ()
    failed_k1 = [f for f in with_bad.failed if f.k == 1]
    assert failed_k1 and all(f.sets == ("equator.csv",) for f in failed_k1)
    assert all("equator.csv" in f.sets for f in with_bad.failed)
    assert with_bad.fits_used[0] == 40 - len(failed_k1) >= 20
    np.testing.assert_allclose(
        with_bad.mean_expanded_uncertainty[0], without.mean_expanded_uncertainty[0], rtol=0.10
    )
    assert np.all(np.isnan(with_bad.values[0][np.isnan(with_bad.values[0, :, 0])]))
    doc = with_bad.to_dict()
    assert [f["sets"] for f in doc["failed_fits"]][: len(failed_k1)] == [["equator.csv"]] * len(
        failed_k1
    )
    assert doc["outputs"][0]["per_k"][0]["fits_used"] == with_bad.fits_used[0]
    assert all(f["reason"] for f in doc["failed_fits"])
    # progress: one call per draw, the last one complete
    assert calls == [(i, 80) for i in range(1, 81)]


def test_a_k_where_every_fit_fails_has_no_coverage_and_says_so():
    _, delta, sigma = _point_sets(0.0)
    r = pooling_experiment(
        MACHINE, [_equator_set(3), _equator_set(4)], delta, sigma, FEATURES[:1],
        REFERENCES[:1], reading_covariance=V, k_values=[1], draws=3, seed=0,
    )  # fmt: skip
    assert r.fits_used.tolist() == [0] and len(r.failed) == 3
    row = r.to_dict()["outputs"][0]["per_k"][0]
    assert (row["coverage"], row["mean_U"], row["fits_used"]) == (None, None, 0)
