"""The identification engine's adequacy rule in the SAMBA calibration (issue 30): probing
noise three times the stated σ scales the covariance by s², the GUF of the scaled inputs
agrees with it, the option keeps the a-priori covariance; residual RMS by ball."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.samba import calibrate, evaluate_uncertainty, indication_inputs

from .samba_helpers import NOISE, simulate


@pytest.fixture(scope="module")
def loud(tmp_path_factory, machine13, truth13, balls, programme, artefact):
    tmp = tmp_path_factory.mktemp("loud")
    return simulate(tmp, machine13, truth13, balls, programme, artefact, noise=3 * NOISE, seed=5)


def _u(doc):
    return np.array([p["u"] for p in doc["parameters"]])


def test_noise_three_times_sigma_scales_and_the_guf_follows(machine13, artefact, loud):
    scaled = calibrate(machine13, loud, artefact, sigma=NOISE, estimate_tool=True)
    kept = calibrate(
        machine13, loud, artefact, sigma=NOISE, estimate_tool=True, adequacy="a-priori"
    )
    a = scaled.identification.adequacy
    assert a.significant and a.scaled and 4.0 < a.factor < 16.0
    assert scaled.covariance_factor == a.factor and kept.covariance_factor == 1.0
    doc, doc_kept = scaled.to_dict(), kept.to_dict()
    np.testing.assert_allclose(_u(doc), np.sqrt(a.factor) * _u(doc_kept), rtol=1e-9)
    assert doc["adequacy"]["scaled"] and not doc_kept["adequacy"]["scaled"]
    assert doc_kept["adequacy"]["significant"]
    # the GUF propagates the inputs the scaled covariance stands for (u·s): the same u to
    # the residual-curvature terms the GUF's sensitivities hold and (JᵀJ)⁻¹ does not (1e-4
    # here); without the scaled inputs it would be 1/s ≈ 1/3 of it
    unc = evaluate_uncertainty(
        scaled, indication_inputs(scaled.problem, noise=NOISE), "noise", method="guf"
    )
    np.testing.assert_allclose(_u(scaled.to_dict(unc)), _u(doc), rtol=1e-3)
    balls = doc["residual_patterns"]["ball"]
    assert sum(g["n"] for g in balls) == len(loud)
    # every ball probed often enough (the scale-bar balls twice only) shows the 3x noise
    assert all(g["rms_weighted"] > 2.0 for g in balls if g["n"] >= 10)


def test_noise_as_stated_is_not_scaled(noisy_calibration):
    a = noisy_calibration.identification.adequacy
    assert a.p_value >= 0.01 and not a.scaled and noisy_calibration.covariance_factor == 1.0
