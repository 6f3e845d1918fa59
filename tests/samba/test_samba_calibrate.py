"""SAMBA calibration: round trips on a virtual machine, nominal-model statistics, rank
refusal with the confounded names (Alami Mchichi (2018) Table 4.4) and the 84-coefficient
model on 17 non-linear (B, C) pairs."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.errors import RankDeficientError
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.samba import ProbingProgramme, calibrate

from .samba_helpers import MACHINE, NOISE, simulate


def test_noise_free_round_trip_recovers_every_parameter_ball_and_the_tool(
    tmp_path, machine13, truth13, balls, programme, artefact
):
    offset = np.array([0.02, -0.015, 0.01])  # true tool-vector correction, mm
    rec = simulate(tmp_path, machine13, truth13, balls, programme, artefact, tool_offset=offset)
    cal = calibrate(machine13, rec, artefact, sigma=NOISE, estimate_tool=True)
    assert cal.identification.success and not cal.minimum_norm
    # records are written to 1 nm: the recovery is at that level
    u = cal.parameters.standard_uncertainty
    assert np.all(np.abs(cal.parameters.values - truth13) < 0.01 * u)
    for b, c in cal.ball_centres().items():
        np.testing.assert_allclose(c, balls[b], atol=5e-6)
    np.testing.assert_allclose(cal.tool, machine13.tool + offset, atol=5e-6)
    assert cal.to_dict()["volumetric_error"]["unexplained"]["max_um"] < 0.01


def test_noisy_round_trip_within_three_standard_uncertainties(noisy_calibration, truth13):
    """Seed-000 Table 5-2 sized errors, 0.5 µm noise: |θ̂ − θ| < 3u for all 13."""
    p = noisy_calibration.parameters
    z = (p.values - truth13) / p.standard_uncertainty
    assert np.all(np.abs(z) < 3.0), z


def test_residuals_have_the_size_of_the_noise_and_the_nominal_model_does_not(
    noisy_calibration,
):
    """RMS residual ≈ σ sqrt(dof / 3n) (3n + 1 rows, 34 unknowns); the nominal model (machine
    errors held at zero) leaves the volumetric errors the calibration removes (Alami Mchichi (2018)
    Tables 6.2, 6.3)."""
    cal = noisy_calibration
    res = cal.residual_vectors
    n = res.shape[0]
    expected = NOISE * np.sqrt(cal.identification.dof / (3 * n))
    rms = np.sqrt(np.mean(np.sum(res**2, axis=1)) / 3)
    assert 0.8 * expected < rms < 1.2 * expected  # 3n − 34 ≈ 300 dof: ±20 % is > 4 sd
    doc = cal.to_dict()["volumetric_error"]
    assert doc["nominal_model"]["mean_um"] > 50 * doc["unexplained"]["mean_um"]


def test_result_is_a_parameter_set_that_predict_reads(noisy_calibration, machine13):
    doc = noisy_calibration.to_dict()
    assert doc["kind"] == "samba-calibration" and doc["version"] == 1
    pset = ParameterSet.from_document(doc, machine13, "RESULT.json")
    np.testing.assert_allclose(pset.values, noisy_calibration.parameters.values)
    np.testing.assert_allclose(pset.covariance, noisy_calibration.parameters.covariance)
    assert {c["name"] for c in doc["conventions"]} == set(machine13.parameter_names)
    assert len(doc["residuals"]) == len(noisy_calibration.records)


def test_without_spindle_indexing_the_tool_is_refused_with_what_to_add(
    tmp_path, machine13, truth13, balls, programme, artefact
):
    keep = programme.s_deg == 0
    prog = ProbingProgramme(
        tuple(b for b, k in zip(programme.balls, keep, strict=True) if k),
        programme.b_deg[keep],
        programme.c_deg[keep],
        programme.s_deg[keep],
    )
    rec = simulate(tmp_path, machine13, truth13, balls, prog, artefact)
    with pytest.raises(RankDeficientError) as err:
        calibrate(machine13, rec, artefact, sigma=NOISE, estimate_tool=True)
    groups = [set(g) for g in err.value.confounded]
    assert {"E_X0S", "tool x"} in groups and {"E_Y0S", "tool y"} in groups
    assert "spindle indexing" in str(err.value)
    flagged = calibrate(
        machine13, rec, artefact, sigma=NOISE, estimate_tool=True, minimum_norm=True
    )
    assert flagged.minimum_norm and flagged.to_dict()["identification"]["minimum_norm"]


def _programme(pairs, bar_pairs=((0, 0), (0, 90))):
    rows = [(b, 0.0, 0.0, 0.0) for b in "1234"]
    rows += [(b, bb, cc, 0.0) for bb, cc in bar_pairs for b in ("SB1", "SB2")]
    rows += [("1", 0.0, 0.0, s) for s in (90.0, 180.0, 270.0)]
    rows += [(b, bb, cc, 0.0) for bb, cc in pairs for b in "1234"]
    cols = list(zip(*rows, strict=True))
    return ProbingProgramme(tuple(cols[0]), *(np.array(c, dtype=float) for c in cols[1:]))


def _nonlinear_pairs(seed):
    """17 (B, C) pairs off any line, on a 15° grid, including (0, 0)."""
    rng = np.random.default_rng(seed)
    cands = [(b, c) for b in range(-90, 91, 15) for c in range(0, 360, 15) if (b, c) != (0, 0)]
    pick = rng.choice(len(cands), 16, replace=False)
    return sorted([(0, 0)] + [cands[i] for i in pick])


@pytest.fixture(scope="module")
def machine84():
    return Machine.load(MACHINE, "84")


def _truth84(machine, programme, balls):
    """Each coefficient moves the stylus by about 5 µm at most over the programme."""
    q = machine.readings_from_customary(
        {
            "X": 0.0,
            "Y": 0.0,
            "Z": 0.0,
            "B": programme.b_deg,
            "C": programme.c_deg,
            "S": programme.s_deg,
        }
    )
    centres = np.array([balls[b] for b in programme.balls])
    senses = np.ones_like(q)
    q = machine.inverse(centres, q, senses=senses)
    jac = machine.jacobian(q, senses=senses)  # (n, 3, 84)
    size = np.abs(jac).max(axis=(0, 1))
    return 0.005 * np.random.default_rng(5).standard_normal(machine.n_params) / size


def test_84_coefficients_identified_on_17_nonlinear_pairs_with_spindle_indexing(
    tmp_path, machine84, balls, artefact
):
    """Alami Mchichi (2018) §4: 4 balls, 17 non-linear (B, C) pairs, spindle indexing:
    84 + 6 × 3 + 3 = 105 unknowns, full rank; noise-free records recover every one."""
    prog = _programme(_nonlinear_pairs(0))
    truth = _truth84(machine84, prog, balls)
    rec = simulate(tmp_path, machine84, truth, balls, prog, artefact)
    cal = calibrate(machine84, rec, artefact, sigma=NOISE, estimate_tool=True)
    diag = cal.identification.diagnostics
    assert diag.rank == 105 == diag.n_unknowns
    u = cal.parameters.standard_uncertainty
    assert np.all(np.abs(cal.parameters.values - truth) < 0.05 * u)


def test_c_equals_3b_is_refused_with_the_six_confounded_pairs(tmp_path, machine84, balls, artefact):
    """Alami Mchichi (2018) Table 4.4: on the line c = 3b (bar probed once, at b = c = 0)
    E_ZC_k pairs with E_ZB_k and E_CB_k with E_CC_k, k = 1, 2, 3."""
    line = [(b, 3 * b) for b in range(-90, 91, 15)]
    prog = _programme(line, bar_pairs=((0, 0),))
    rec = simulate(tmp_path, machine84, None, balls, prog, artefact)
    with pytest.raises(RankDeficientError) as err:
        calibrate(machine84, rec, artefact, sigma=NOISE, estimate_tool=True)
    pairs = {frozenset(g) for g in err.value.confounded}
    expected = {frozenset({f"E_ZC{k}", f"E_ZB{k}"}) for k in (1, 2, 3)}
    expected |= {frozenset({f"E_CB{k}", f"E_CC{k}"}) for k in (1, 2, 3)}
    assert pairs == expected
    assert "off any straight line" in str(err.value)


def test_the_estimated_tool_is_in_the_parameter_set_and_read_back(noisy_calibration):
    """What the calibration identifies (--estimate-tool), compensation uses: the result
    document's tool_mm is read back into the parameter set and onto the machine."""
    cal = noisy_calibration
    np.testing.assert_array_equal(cal.parameters.tool, cal.tool)
    back = ParameterSet.from_document(cal.to_dict(), cal.machine, "result.json")
    np.testing.assert_allclose(back.tool, cal.tool, rtol=0, atol=1e-12)
    np.testing.assert_allclose(back.machine_for(cal.machine).tool, cal.tool, rtol=0, atol=1e-12)
    assert np.linalg.norm(cal.tool - cal.machine.tool) > 0  # identified, not the nominal
    doc = {**cal.to_dict(), "tool_estimated": False}  # a calibration that did not estimate it
    assert ParameterSet.from_document(doc, cal.machine, "result.json").tool is None
