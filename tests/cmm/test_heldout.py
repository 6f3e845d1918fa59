"""Kinematic against GP on held-out positions, judged on the plate certificate's lengths."""

from __future__ import annotations

import numpy as np
import pytest
from cmm_virtual import DIAGONAL, SIGMA, TRAIN, make_positions

from mtmetrology.cmm.heldout import HeldOutComparison, _plate_variance, compare_held_out
from mtmetrology.cmm.simulate import simulate_ballplate
from mtmetrology.errors import InputError

FEW = ["P0", "PX1", "PY1"]


@pytest.fixture(scope="module")
def records(truth, plate3, probes):
    machine, theta = truth
    specs = [(i, o, r, FEW) for i, o, r, _ in [*TRAIN, DIAGONAL]]
    camp = simulate_ballplate(
        machine, theta, plate3, make_positions(*specs), probes, sigma=SIGMA, seed=23,
        perturb_plate=False,
    )  # fmt: skip
    return camp.records


@pytest.fixture(scope="module")
def comparison(base, records, plate3, probes):
    return compare_held_out(
        base, records, plate3, probes, ["D"], sigma=SIGMA, kinematic_model="full-3"
    )


def test_models_beat_no_compensation_on_the_held_out_diagonal(comparison):
    unc, kin, gp = (comparison.row(m) for m in ("uncompensated", "kinematic", "GP"))
    # 3 probes x C(9, 2) lengths of the one held-out position
    assert unc["n_lengths"] == kin["n_lengths"] == gp["n_lengths"] == 3 * 36
    assert kin["rms_error_um"] < 0.3 * unc["rms_error_um"]
    assert gp["rms_error_um"] < unc["rms_error_um"]
    # the uncompensated u holds only the noise and the plate: sqrt(2 σ² + 2 u_plate²)
    u0 = np.sqrt(2 * 0.5**2 + 2 * 0.5**2)
    np.testing.assert_allclose(comparison.plot["uncompensated"]["u_um"], u0, rtol=1e-9)
    for r in comparison.table:
        assert kin["mean_u_um"] > u0 - 1e-9 and 0.0 <= r["coverage"] <= 1.0


def test_round_trip(comparison):
    doc = comparison.to_dict()
    assert HeldOutComparison.from_dict(doc).to_dict() == doc
    assert doc["settings"]["kinematic_model"].startswith("full-3")
    assert doc["provenance"]["train_positions"] == ["H", "VX", "VY", "T"]


def test_plate_variance_of_diagonal_covariance_is_2u2(plate3):
    v = _plate_variance(plate3, list(plate3.ids))
    np.testing.assert_allclose(v, 2 * 0.0005**2, rtol=1e-12)


def test_refuses_unknown_or_all_positions(base, records, plate3, probes):
    with pytest.raises(InputError, match="--held-out 'Q': not a position"):
        compare_held_out(base, records, plate3, probes, ["Q"], sigma=SIGMA)
    with pytest.raises(InputError, match="leave at least one position"):
        compare_held_out(base, records, plate3, probes, records.position_ids, sigma=SIGMA)
