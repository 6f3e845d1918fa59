"""Tests of mtmetrology.omm.repeatability_model: the pose models of eqs. 4-1 and 4-2
(Sepahi Boroujeni 2021) fitted on simulated records from known coefficients."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy import stats as sps

from mtmetrology.errors import InputError
from mtmetrology.omm.repeatability import factors_from_file_units, sphere_normal, target_statistics
from mtmetrology.omm.repeatability_model import (
    COVARIANCE_DEGREES,
    STD_DEGREES,
    PoseRangeWarning,
    fit_repeatability_model,
    separable_design,
)
from mtmetrology.units import to_internal

# Table 4-1 ranges (deg, deg, deg, deg, mm, mm, mm).
LOW = factors_from_file_units(0, 0, -90, -180, -220, -170, -110)[0]
HIGH = factors_from_file_units(90, 360, 90, 180, 230, 180, 220)[0]
UM = to_internal(1.0, "µm")

# Known model coefficients on normalised factors (µm, µm²), inside the spans of eqs. 4-1/4-2.
TRUE_STD = {
    0: {0: 0.9, 1: 0.15, 3: -0.1, 13: 0.1},  # σ_X: const, φ, θ, X_T
    1: {0: 1.0, 2: 0.1, 4: 0.12, 10: -0.1},  # σ_Y: const, φ², θ², C
    2: {0: 0.8, 7: 0.1, 16: 0.1, 20: 0.05},  # σ_Z: const, B, Y_T, Z_T²
}
TRUE_COV = {
    0: {0: 0.05, 6: 0.2, 7: 0.05},  # cov(X,Y): const, θ, θ²
    1: {0: 0.1, 16: -0.1},  # cov(X,Z): const, C
    2: {0: -0.05, 31: 0.08},  # cov(Y,Z): const, Z_T
}


def _coefficients(table, p):
    out = np.zeros((len(table), p))
    for j, terms in table.items():
        for k, v in terms.items():
            out[j, k] = v
    return out


C_STD = _coefficients(TRUE_STD, 22) * UM
C_COV = _coefficients(TRUE_COV, 36) * UM * UM


def true_covariance(z):
    s = separable_design(z, STD_DEGREES) @ C_STD.T  # (n, 3)
    c = separable_design(z, COVARIANCE_DEGREES) @ C_COV.T  # (n, 3): XY, XZ, YZ
    cov = np.empty((*z.shape[:-1], 3, 3))
    cov[..., [0, 1, 2], [0, 1, 2]] = s**2
    cov[..., 0, 1] = cov[..., 1, 0] = c[..., 0]
    cov[..., 0, 2] = cov[..., 2, 0] = c[..., 1]
    cov[..., 1, 2] = cov[..., 2, 1] = c[..., 2]
    return cov, s


def simulated_records(n_targets, touches, seed):
    rng = np.random.default_rng(seed)
    z = rng.uniform(-1, 1, (n_targets, 7))
    z[:2] = [[-1] * 7, [1] * 7]  # the range limits themselves are poses
    factors = LOW + (z + 1) / 2 * (HIGH - LOW)
    cov, _ = true_covariance(z)
    assert np.all(np.linalg.eigvalsh(cov) > 0)
    normal = sphere_normal(factors[:, 0], factors[:, 1])
    centre = factors[:, 4:] - 15.7 * normal
    noise = np.einsum(
        "tij,tkj->tki", np.linalg.cholesky(cov), rng.standard_normal((n_targets, touches, 3))
    )
    readings = factors[:, None, 4:] + noise
    readings[:, 0] += 0.002  # first touch off by 2 µm (hysteresis): must be discarded
    m = n_targets * touches
    return dict(
        target=[f"t{t}" for t in np.repeat(np.arange(n_targets), touches)],
        factors=np.repeat(factors, touches, axis=0),
        readings=readings.reshape(m, 3),
        normal=np.repeat(normal, touches, axis=0),
        time=np.tile(np.arange(touches, dtype=float), n_targets),
        centre=np.repeat(centre, touches, axis=0),
    )


@pytest.fixture(scope="module")
def fitted():
    rec = simulated_records(250, 201, seed=12)
    st = target_statistics(**rec)
    return st, fit_repeatability_model(st, holdout=0.15, seed=3, factor_ranges=(LOW, HIGH))


def test_fitted_model_recovers_known_coefficients(fitted):
    """Each coefficient within its uncertainty: |ĉ − c| / u below the Bonferroni t bound.

    All 3·22 + 3·36 = 174 standardised errors of the X, Y, Z outputs must lie below the
    two-sided t quantile at family-wise level 1 % (t with n_fit − p degrees of freedom).
    """
    _, model = fitted
    fits = {f.name: f for f in model.fits}
    truth = [("sigma_X", C_STD[0]), ("sigma_Y", C_STD[1]), ("sigma_Z", C_STD[2])]
    truth += [("cov_XY", C_COV[0]), ("cov_XZ", C_COV[1]), ("cov_YZ", C_COV[2])]
    m = sum(len(c) for _, c in truth)
    for name, c in truth:
        f = fits[name]
        bound = sps.t.ppf(1 - 0.01 / (2 * m), model.n_fit - len(c))
        assert np.max(np.abs(f.coefficients - c) / f.standard_uncertainties) < bound, name


def test_held_out_sigma_within_10_percent_of_truth(fitted):
    """At 200 poses not used in the fit, predicted σ within 10 % of the true σ.

    200 touches per target give σ to 5 % per target; 212 fitting targets for 22
    coefficients bring the prediction to about 2 % (max over 200 poses about 6 %).
    """
    _, model = fitted
    rng = np.random.default_rng(99)
    z = rng.uniform(-1, 1, (200, 7))
    factors = LOW + (z + 1) / 2 * (HIGH - LOW)
    _, s_true = true_covariance(z)
    pred = model.predict(factors)
    for j, name in enumerate(("sigma_X", "sigma_Y", "sigma_Z")):
        assert np.max(np.abs(pred[name] - s_true[:, j]) / s_true[:, j]) < 0.10, name
    assert model.n_validation == 38
    assert all(f.validation_max_abs_error is not None for f in model.fits)


def test_predicted_covariance_is_psd_and_five_axis_readings_have_zero_rotary_rows(fitted):
    _, model = fitted
    z = np.random.default_rng(5).uniform(-1, 1, (50, 7))
    factors = LOW + (z + 1) / 2 * (HIGH - LOW)
    c3 = model.covariance(factors)
    assert np.all(np.linalg.eigvalsh(c3) >= -1e-18)
    assert np.allclose(c3, np.swapaxes(c3, -1, -2))
    c5 = model.reading_covariance(factors[0], ("X", "Y", "Z", "B", "C"))
    assert c5.shape == (5, 5) and np.all(c5[3:] == 0) and np.all(c5[:, 3:] == 0)
    np.testing.assert_allclose(c5[:3, :3], c3[0], rtol=1e-12, atol=1e-20)  # batched eigh


def test_reading_covariance_places_the_block_by_axis_name_for_any_axis_count(fitted):
    """Topology-generic: 3, 5 or 6 axes in any order get the same X, Y, Z block, placed by
    name, and zero rows for the others; a machine without Z is refused naming the axis."""
    _, model = fitted
    pose = (LOW + HIGH) / 2
    c3 = model.covariance(pose)
    for names in [("X", "Y", "Z"), ("C", "Z", "A", "X", "Y"), ("W", "X", "B", "Y", "C", "Z")]:
        v = model.reading_covariance(pose, names)
        idx = [names.index(a) for a in "XYZ"]
        np.testing.assert_array_equal(v[np.ix_(idx, idx)], c3)
        others = [i for i in range(len(names)) if i not in idx]
        assert v.shape == (len(names),) * 2
        assert np.all(v[others] == 0) and np.all(v[:, others] == 0)
    stacked = model.reading_covariance(np.stack([pose, pose]), ("X", "Y", "Z", "B"))
    assert stacked.shape == (2, 4, 4)
    with pytest.raises(InputError, match=r"^axis_names: .*; Z missing from \['X', 'Y', 'C'\]$"):
        model.reading_covariance(pose, ("X", "Y", "C"))


def test_pose_outside_range_is_refused_or_warned_naming_the_factor(fitted):
    _, model = fitted
    pose = (LOW + HIGH) / 2
    pose[5] = HIGH[5] + 10.0  # Y_T 10 mm beyond the range
    with pytest.raises(InputError, match="Y_T"):
        model.covariance(pose)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model.covariance(pose, strict=False)
    assert [w.category for w in caught] == [PoseRangeWarning]


def test_to_dict_lists_22_and_36_coefficients_in_micrometres(fitted):
    _, model = fitted
    doc = model.to_dict()
    assert doc["kind"] == "repeatability-model" and doc["version"] == 1
    sizes = {o["name"]: len(o["coefficients"]) for o in doc["outputs"]}
    assert sizes == {
        **dict.fromkeys(("sigma_X", "sigma_Y", "sigma_Z", "sigma_N", "sigma_T"), 22),
        **dict.fromkeys(("cov_XY", "cov_XZ", "cov_YZ", "cov_NT"), 36),
    }
    sx = next(o for o in doc["outputs"] if o["name"] == "sigma_X")
    assert sx["unit"] == "µm" and sx["coefficients"][0] == pytest.approx(0.9, abs=0.1)
    assert doc["factors"][1] == {"name": "theta", "unit": "deg", "low": 0.0, "high": 360.0}


def test_too_few_targets_and_too_few_levels_are_refused():
    st = target_statistics(**simulated_records(40, 5, seed=2))
    with pytest.raises(InputError, match="more than 36"):
        fit_repeatability_model(st, holdout=0.15)
    rec = simulated_records(45, 5, seed=2)
    with pytest.raises(InputError, match=r"45 fitting targets .* fewer than 3 per coefficient"):
        fit_repeatability_model(target_statistics(**rec), holdout=0.0)
    rec["factors"][:, 6] = 7.0  # Z_T constant
    with pytest.raises(InputError, match="Z_T"):
        fit_repeatability_model(
            target_statistics(**rec), holdout=0.0, min_targets_per_coefficient=0
        )


def test_held_out_rms_relative_error_is_bounded_by_the_largest(fitted):
    """√(Σd²/Σy²) ≤ max |d|/|y| (Σd² = Σ(d/y)² y²); flagged exactly above 50 %."""
    for fit in fitted[1].fits:
        assert 0 <= fit.validation_rms_relative_error <= fit.validation_max_relative_error
        assert fit.validation_flagged == (fit.validation_rms_relative_error > 0.5)


def test_model_document_round_trips_through_a_strict_file(fitted, tmp_path):
    from mtmetrology.io import write_json
    from mtmetrology.omm.repeatability_file import load_repeatability_model

    _, model = fitted
    path = tmp_path / "R.json"
    write_json(path, model.to_dict())
    loaded = load_repeatability_model(path)
    pose = (LOW + HIGH) / 2
    assert np.allclose(loaded.covariance(pose), model.covariance(pose), rtol=1e-12, atol=0)
    assert np.allclose(loaded.factor_high, model.factor_high, rtol=1e-15)


@pytest.mark.parametrize(
    ("edit", "field"),
    [
        (lambda d: d.update(extra=1), "extra"),
        (lambda d: d["outputs"][0]["coefficients"].pop(), "sigma_X"),
        (lambda d: d["factors"].reverse(), "factors"),
        (lambda d: d["factors"][4].update(high=-1000.0), "X_T"),
        (lambda d: d["outputs"].reverse(), "outputs"),
    ],
)
def test_bad_model_documents_are_refused_naming_the_field(fitted, tmp_path, edit, field):
    from mtmetrology.io import write_json
    from mtmetrology.omm.repeatability_file import load_repeatability_model

    doc = fitted[1].to_dict()
    edit(doc)
    path = tmp_path / "R.json"
    write_json(path, doc)
    with pytest.raises(InputError, match=field) as err:
        load_repeatability_model(path)
    assert "\n" not in str(err.value)
