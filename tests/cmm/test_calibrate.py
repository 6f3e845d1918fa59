"""Kinematic ball-plate calibration on a virtual CMM with known errors."""

from __future__ import annotations

import numpy as np
import pytest
from cmm_virtual import ALL, DIAGONAL, SIGMA, TRAIN, make_plate, make_positions
from scipy import stats

from mtmetrology.cmm.calibrate import calibrate_ballplate, cross_validate
from mtmetrology.cmm.compare import length_errors
from mtmetrology.cmm.models import SQUARENESS
from mtmetrology.cmm.simulate import simulate_ballplate
from mtmetrology.errors import RankDeficientError


def _campaign(truth, plate, probes, specs, seed):
    machine, theta = truth
    return simulate_ballplate(
        machine, theta, plate, make_positions(*specs), probes, sigma=SIGMA, seed=seed
    )


def _held_out_lengths(cal, base, camp, probes):
    """Uncompensated and compensated length errors (and u) on the held-out position D."""
    rec = camp.records
    test = np.array([p == "D" for p in rec.positions])
    out = {"raw": [], "comp": [], "u": []}
    for pid in dict.fromkeys(rec.probes):
        s = test & np.array([p == pid for p in rec.probes])
        q, t = rec.readings[s], probes.offsets([pid])[0]
        raw = base.with_parameters([]).forward(q, None, tool=t)
        n = int(s.sum())
        _, e_raw, _ = length_errors(raw, camp.true_points[s], np.zeros((3, n, n)), SIGMA)
        pts = cal.compensate(q, t)
        jac = cal.machine.jacobian(q, cal.theta, tool=t)
        cov = np.stack([jac[:, c] @ cal.parameters.covariance @ jac[:, c].T for c in range(3)])
        _, e, u = length_errors(pts, camp.true_points[s], cov, SIGMA)
        out["raw"].append(e_raw)
        out["comp"].append(e)
        out["u"].append(u)
    return {k: np.concatenate(v) for k, v in out.items()}


def test_held_out_diagonal_lengths_and_coverage(base, truth, plate3, probes):
    """Calibrate on 4 positions, predict the lengths of a held-out diagonal plate.

    Accuracy: the RMS length error after compensation is below 15 % of the uncompensated
    one (reached: median 8 %, 6.5–9.4 % over the campaigns, from ~11 µm RMS).  Coverage:
    over R = 24 independent campaigns, the longest
    compensated length of each (one per campaign, so the trials are independent) is
    covered by ±2u; under a correct uncertainty the count is Binomial(24, 0.9545), and a
    two-sided binomial test at the 1 % level must not reject it.
    """
    ratios, covered = [], 0
    R = 24
    for r in range(R):
        camp = _campaign(truth, plate3, probes, [*TRAIN, DIAGONAL], seed=100 + r)
        train = camp.records.subset(np.array([p != "D" for p in camp.records.positions]))
        cal = calibrate_ballplate(base, train, plate3, probes, model="full-3", sigma=SIGMA)
        e = _held_out_lengths(cal, base, camp, probes)
        ratios.append(np.sqrt(np.mean(e["comp"] ** 2) / np.mean(e["raw"] ** 2)))
        i = np.argmax(np.abs(e["raw"]))
        covered += bool(abs(e["comp"][i]) <= 2.0 * e["u"][i])
    assert np.median(ratios) < 0.15
    p = stats.binomtest(covered, R, 0.9545).pvalue
    assert p > 0.01, (covered, R)


def test_horizontal_only_is_rank_deficient_and_vertical_fixes_it(base, truth, plate3, probes):
    """One plate height: a Z scale error is a plate shift (Salacheep 2016, §4.6: location 0
    alone is rank deficient); the error names it; a vertical position separates it."""
    horizontal = [("H1", [330, 230, 150], [0, 0, 0], ALL), ("H2", [600, 200, 150], [0, 0, 90], ALL)]
    camp = _campaign(truth, plate3, probes, horizontal, seed=3)
    with pytest.raises(RankDeficientError) as err:
        calibrate_ballplate(base, camp.records, plate3, probes, model="seed", sigma=SIGMA)
    assert any("E_ZZ1" in group for group in err.value.confounded)
    camp = _campaign(truth, plate3, probes, [*horizontal, TRAIN[1]], seed=3)
    cal = calibrate_ballplate(base, camp.records, plate3, probes, model="seed", sigma=SIGMA)
    assert cal.identification.diagnostics.full_rank


@pytest.fixture(scope="module")
def campaign(truth, plate3, probes):
    return _campaign(truth, plate3, probes, [*TRAIN, DIAGONAL], seed=11)


def _lengths(cal, camp, probes):
    rec = camp.records
    pts = cal.compensate(rec.readings, probes.offsets(rec.probes))
    a, b = np.triu_indices(len(pts), 1)
    return np.linalg.norm(pts[a] - pts[b], axis=1)


def test_compensation_independent_of_basis(base, campaign, plate3, probes):
    """Monomial, Legendre and Chebyshev span the same functions: same fit, same lengths.

    The bases differ by constant terms, which the datum absorbs in the plate poses (exactly
    to first order); the compensated lengths agree to 0.01 µm (1/50 of the reading noise),
    the residue being second order in the errors (constant angles × lengths).
    """
    out = {
        b: calibrate_ballplate(
            base, campaign.records, plate3, probes, model="full-2", sigma=SIGMA, basis=b
        )
        for b in ("monomial", "legendre", "chebyshev")
    }
    ref = _lengths(out["chebyshev"], campaign, probes)
    for cal in out.values():
        cost = out["chebyshev"].identification.cost
        assert cal.identification.cost == pytest.approx(cost, rel=1e-5)
        np.testing.assert_allclose(_lengths(cal, campaign, probes), ref, rtol=0, atol=1e-5)


def test_compensation_independent_of_equivalent_datum(base, campaign, plate3, probes):
    """Straightness slopes kept instead of the squareness errors: an equivalent datum."""
    slopes = ("E_XY1", "E_ZX1", "E_ZY1")
    alt = calibrate_ballplate(
        base, campaign.records, plate3, probes, model="full-2", sigma=SIGMA, prefer=slopes
    )
    ref = calibrate_ballplate(base, campaign.records, plate3, probes, model="full-2", sigma=SIGMA)
    assert set(SQUARENESS) <= {n for n, _ in alt.datum.dropped}
    assert set(slopes) <= set(alt.machine.parameter_names)
    assert alt.identification.cost == pytest.approx(ref.identification.cost, rel=1e-5)
    np.testing.assert_allclose(
        _lengths(alt, campaign, probes), _lengths(ref, campaign, probes), rtol=0, atol=1e-5
    )


def test_seed_model_is_recovered_exactly(base, plate3, probes):
    """Truth in the seed model, no noise, certificate plate: the fit returns the truth."""
    machine = base
    rng = np.random.default_rng(5)
    # 5 µm and 5 µrad in the customary units of each coefficient
    theta = rng.normal(0.0, 5.0, machine.n_params) * machine.parameter_scales
    camp = simulate_ballplate(
        machine, theta, plate3, make_positions(*TRAIN), probes, sigma=0.0, perturb_plate=False
    )
    cal = calibrate_ballplate(base, camp.records, plate3, probes, model="seed", sigma=SIGMA)
    scales = machine.parameter_scales  # compare in µm and µrad: to 1e-3 (1 nm, 1 nrad)
    np.testing.assert_allclose(cal.theta / scales, theta / scales, rtol=0, atol=1e-3)
    assert cal.summary["rank"] == len(cal.identification.names)


def test_auto_model_selection_prefers_adequate_model(base, truth, probes):
    """Truth of degree 3: leave-one-position-out prefers the degree-3 model to the seed's.

    A 4 x 4 plate: with 3 balls per row a degree-3 function is not determined once a
    position is left out (the fold's score then explodes, as it should).
    """
    plate4 = make_plate(4, 177.0)
    camp = _campaign(truth, plate4, probes, TRAIN, seed=11)
    sel = cross_validate(base, camp.records, plate4, probes, ["seed", "full-3"], sigma=SIGMA)
    scores = {s["model"]: s["mean_rms_um"] for s in sel["scores"]}
    assert sel["chosen"] == "full-3"
    assert scores["full-3"] < scores["seed"]


def test_chi_square_flags_an_inadequate_model(base, campaign, plate3, probes):
    """Degree-3 truth: the seed model leaves structure in the residuals (χ² p < 1e-6); the
    degree-3 model does not (p > 0.01, a 1 % level test at this fixed seed)."""
    train = campaign.records.subset(np.array([p != "D" for p in campaign.records.positions]))
    p = {
        m: calibrate_ballplate(base, train, plate3, probes, model=m, sigma=SIGMA).to_document()[
            "fit"
        ]["chi2_p_value"]
        for m in ("seed", "full-3")
    }
    assert p["seed"] < 1e-6
    assert p["full-3"] > 0.01
