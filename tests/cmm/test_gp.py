"""Gaussian-process error model and the kinematic-vs-GP comparison."""

from __future__ import annotations

import numpy as np
import pytest
from cmm_virtual import DIAGONAL, SIGMA, TRAIN, make_positions

from mtmetrology.cmm.compare import compare_models
from mtmetrology.cmm.gp import GPErrorModel, fit_gp
from mtmetrology.cmm.simulate import simulate_ballplate

FEW = ["P0", "PX1", "PY1"]


@pytest.fixture(scope="module")
def campaign(truth, plate3, probes):
    machine, theta = truth
    specs = [(i, o, r, FEW) for i, o, r, _ in [*TRAIN, DIAGONAL]]
    return simulate_ballplate(
        machine, theta, plate3, make_positions(*specs), probes, sigma=SIGMA, seed=21
    )


@pytest.fixture(scope="module")
def train(campaign):
    return campaign.records.subset(np.array([p != "D" for p in campaign.records.positions]))


@pytest.mark.parametrize(("mean", "kernel"), [("seed", "rbf"), (None, "matern")])
def test_gp_compensates_training_positions(base, campaign, train, plate3, probes, mean, kernel):
    """On the training positions the GP-compensated points lie closer to the truth (after
    removing each position's translation) than the uncompensated ones, by >= 30 %."""
    gp = fit_gp(base, train, plate3, probes, sigma=SIGMA, mean=mean, kernel=kernel)
    tools = probes.offsets(train.probes)
    pts, u = gp.predict(train.readings, tools)
    raw = base.with_parameters([]).forward(train.readings, None, tool=tools)
    keep = np.array([p != "D" for p in campaign.records.positions])
    truth = campaign.true_points[keep]

    def rms_after_rigid(points):
        out = []
        for pid in train.position_ids:
            s = np.array([p == pid for p in train.positions])
            d = points[s] - points[s].mean(0) - (truth[s] - truth[s].mean(0))
            out.append(np.sqrt(np.mean(d**2)))
        return np.mean(out)

    # reached: 0.37 (kinematic mean), 0.60 (zero mean: pose and error field alternate)
    assert rms_after_rigid(pts) < 0.7 * rms_after_rigid(raw)
    assert np.all(u > 0)


def test_gp_model_file_round_trip(base, train, plate3, probes):
    """Saved hyper-parameters and training data rebuild the same predictions."""
    gp = fit_gp(base, train, plate3, probes, sigma=SIGMA, mean="seed")
    again = GPErrorModel.from_document(gp.to_document(), base)
    q, t = train.readings[:7], probes.offsets(train.probes[:7])
    a, ua = gp.predict(q, t)
    b, ub = again.predict(q, t)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12)
    np.testing.assert_allclose(ua, ub, rtol=1e-9, atol=1e-15)


def test_comparison_table_and_plot(base, truth, plate3, probes):
    """Held-out diagonal: both models beat no compensation; the table carries coverage."""
    machine, theta = truth
    campaign = simulate_ballplate(
        machine, theta, plate3, make_positions(*TRAIN, DIAGONAL), probes, sigma=SIGMA, seed=22
    )
    c = compare_models(base, campaign, plate3, probes, "D", sigma=SIGMA, kinematic_model="full-3")
    rows = {r["model"]: r for r in c.table}
    assert set(rows) == {"uncompensated", "kinematic full-3", "GP (rbf)"}
    assert rows["kinematic full-3"]["rms_error_um"] < 0.2 * rows["uncompensated"]["rms_error_um"]
    assert rows["GP (rbf)"]["rms_error_um"] < rows["uncompensated"]["rms_error_um"]
    for r in c.table:
        assert 0.0 <= r["coverage"] <= 1.0 and r["n_lengths"] == 5 * 36
        assert np.isfinite(r["mean_u_um"]) and r["mean_u_um"] > 0
        assert len(c.plot[r["model"]]["error_um"]) == r["n_lengths"]
    assert c.to_dict()["kind"] == "cmm-model-comparison"
