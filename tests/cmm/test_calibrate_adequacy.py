"""The identification engine's adequacy rule in the ball-plate calibration (issue 30): a
model that misses the truth (seed model, degree-3 truth) is flagged and its covariance and
U1–U3 scaled by s²; the option keeps them; the residual RMS by position and stylus."""

from __future__ import annotations

import numpy as np
import pytest
from cmm_virtual import SIGMA, TRAIN, make_positions

from mtmetrology.cmm.calibrate import calibrate_ballplate
from mtmetrology.cmm.simulate import simulate_ballplate


@pytest.fixture(scope="module")
def records(truth, plate3, probes):
    machine, theta = truth
    camp = simulate_ballplate(
        machine, theta, plate3, make_positions(*TRAIN), probes, sigma=SIGMA, seed=11
    )
    return camp.records


def test_inadequate_model_scales_u1_u3_and_the_option_keeps_them(base, records, plate3, probes):
    scaled = calibrate_ballplate(base, records, plate3, probes, model="seed", sigma=SIGMA)
    kept = calibrate_ballplate(
        base, records, plate3, probes, model="seed", sigma=SIGMA, adequacy="a-priori"
    )
    a = scaled.identification.adequacy
    assert a.significant and a.scaled and a.factor > 1.0
    assert kept.identification.adequacy.significant and not kept.identification.adequacy.scaled
    np.testing.assert_allclose(
        scaled.parameters.covariance, a.factor * kept.parameters.covariance, rtol=1e-10
    )
    for key in ("U1_um", "U2_um", "U3_um"):
        np.testing.assert_allclose(
            scaled.summary[key], np.sqrt(a.factor) * np.asarray(kept.summary[key]), rtol=1e-9
        )
    doc = scaled.to_document()
    assert doc["adequacy"]["scaled"] and doc["adequacy"]["p_value"] == doc["fit"]["chi2_p_value"]
    patterns = doc["residual_patterns"]
    assert {g["group"] for g in patterns["position"]} == {p[0] for p in TRAIN}
    assert {g["group"] for g in patterns["probe"]} == set(records.probes)
    assert sum(g["n"] for g in patterns["probe"]) == len(records.readings)
    # the misfit is in the residuals: some group's weighted rms stands above the noise
    assert max(g["rms_weighted"] for g in patterns["position"]) > 1.2


def test_adequate_model_is_not_scaled(base, records, plate3, probes):
    cal = calibrate_ballplate(base, records, plate3, probes, model="full-3", sigma=SIGMA)
    a = cal.identification.adequacy
    assert a.p_value > 0.01 and not a.scaled and a.factor == 1.0
