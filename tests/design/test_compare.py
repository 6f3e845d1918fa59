"""The strategy comparison (``mtm samba compare-plans``) against Alami Mchichi (2018) Tables A.1
and 5.3, and the simulated gauge-block check."""

import json

import numpy as np
import pytest
from lab_balls import LAB_CENTRES, LAB_IDS

from mtmetrology.design.compare import StrategyComparison, compare_strategies
from mtmetrology.design.inputs import ScaleBarPlacement, default_indexations
from mtmetrology.design.programme import evaluate_programme
from mtmetrology.errors import InputError

PAIRS = default_indexations()


def test_condition_with_all_450_indexations_follows_table_a1_within_20_percent(m13):
    """Table A.1 (O2, 13 parameters, 450 (B, C) pairs): 44.6, 59.5, 73.0, 84.3 for 1-4
    balls. Here the nested laboratory balls (not the source's DETMAX-chosen ones, whose
    positions are not published) and column-scaled Jacobian of balls, bar and tool
    unknowns (the source does not state its normalisation): measured 37.5, 61.3, 72.5,
    93.1, i.e. -16 %, +3 %, -1 %, +10 %. Tolerance 20 %."""
    conds = [
        evaluate_programme(m13, LAB_IDS[:n], LAB_CENTRES[:n], PAIRS).report.condition_scaled
        for n in (1, 2, 3, 4)
    ]
    np.testing.assert_allclose(conds, [44.6, 59.5, 73.0, 84.3], rtol=0.2)
    assert np.all(np.diff(conds) > 0)  # one ball is best (Table 5.2's trend)


def test_detmax_improvement_of_4b2n_follows_table_5_3(m84):
    """Table 5.3, 84 parameters, 4B.2n: DETMAX takes the random start subset from 1058 to
    469, 55.7 %; the optimised subset beats all candidates (469 < Cond_N = 482). Small
    sweep (every third of the 450 pairs, one start; the 450-pair run is in
    bench/study_design_compare.py): improvement within 10 points of 55.7 % (measured
    53.5 %), and the end below Cond_N."""
    res = compare_strategies(
        m84, PAIRS[::3], (LAB_IDS, LAB_CENTRES), n_balls=(4,), ks=(2,), starts=1, seed=1
    )
    (s,) = res.strategies
    assert s.name == "4B.2n O2" and s.n_indexations == 13
    assert s.improvement == pytest.approx(0.557, abs=0.10)
    assert s.condition_end < s.condition_all < s.condition_start


def test_sweep_gives_every_strategy_its_figures_and_round_trips(m13):
    """1 and 4 balls × k = 2, 3: duration grows with the measurements, each strategy's UPF
    is its predicted u per µm of σ, the compensated model cuts the gauge-block error
    (true errors within ±50 µm, µrad, µm/m) tenfold at σ = 0.1 µm and a bar of u = 0.1 µm
    (what is left is that noise through the UPF), and the file form reads back equal."""
    seen: list = []
    res = compare_strategies(
        m13,
        PAIRS[::9],
        (LAB_IDS, LAB_CENTRES),
        n_balls=(1, 4),
        ks=(2, 3),
        starts=1,
        seed=3,
        sigma_mm=0.0001,
        bar=ScaleBarPlacement(u_mm=0.0001),
        progress=lambda *a: seen.append(a),
    )
    assert [s.name for s in res.strategies] == ["1B.2n O2", "1B.3n O2", "4B.2n O2", "4B.3n O2"]
    assert seen == [(1, 4), (2, 4), (3, 4), (4, 4)]  # a progress report per strategy
    d = [s.duration_h for s in res.strategies]
    m = [s.n_measurements for s in res.strategies]
    assert np.all(np.argsort(d) == np.argsort(m))
    for s in res.strategies:
        assert s.condition_end <= s.condition_start
        assert s.gauge_calibrated_um < 0.1 * s.gauge_nominal_um
        for p in s.parameters:
            assert p["upf"] == pytest.approx(p["u"] / 0.1, rel=1e-12)
    back = StrategyComparison.from_dict(json.loads(json.dumps(res.to_dict())))
    assert back == res
    header, rows = res.table()
    assert len(rows) == 4 and len(header) == len(rows[0])


def test_bad_sweep_is_refused_naming_the_option(m13):
    with pytest.raises(InputError, match="--n-balls 5"):
        compare_strategies(m13, PAIRS, (LAB_IDS, LAB_CENTRES), n_balls=(5,))
    with pytest.raises(InputError, match="--k 0"):
        compare_strategies(m13, PAIRS, (LAB_IDS, LAB_CENTRES), ks=(0,))
