"""ISO 230-4 G, H, F against an independent computation on a constructed test."""

from __future__ import annotations

import numpy as np

from mtmetrology.ballbar.iso230_4 import circular_deviation, circular_results
from mtmetrology.ballbar.records import BallbarConditions, nominal_test

CONDITIONS = BallbarConditions("XY", 100.0, 1000.0, np.zeros(3), name="xy")


def _test():
    test = nominal_test(CONDITIONS, 360)
    th = test.angle
    # offset centre (8, −5) µm (the least-squares circle removes it), 3-lobed form of
    # amplitude 3 µm, and 4 sin²θ µm more on the clockwise run
    form = 3e-3 * np.cos(3 * th)
    ell = 8e-3 * np.cos(th) - 5e-3 * np.sin(th) + form
    ell = ell + np.where(test.direction == -1, 4e-3 * np.sin(th) ** 2, 0.0)
    return test.with_reading(ell), form


def test_g_h_f_match_independent_values():
    test, form = _test()
    res = circular_results(test).to_dict()
    # G about the least-squares centre: the 3-lobe form alone, 6 µm peak to valley
    assert abs(res["circular_deviation_G"]["ccw"] - 6.0) < 1e-3
    # the clockwise extra 4 sin²θ = 2 − 2 cos 2θ adds its own range about the LSC
    ccw = test.direction == 1
    extra = form[ccw] + 4e-3 * np.sin(test.angle[ccw]) ** 2
    expected_cw = (extra.max() - extra.min()) * 1e3
    assert abs(res["circular_deviation_G"]["cw"] - expected_cw) < 1e-3
    assert abs(res["circular_hysteresis_H"] - 4.0) < 1e-9
    ell_ccw = test.reading[ccw] * 1e3
    assert res["radial_deviation_F"]["ccw"]["max"] == ell_ccw.max()
    assert res["radial_deviation_F"]["ccw"]["min"] == ell_ccw.min()
    np.testing.assert_allclose(res["least_squares_centre_um"]["ccw"], [8.0, -5.0], atol=1e-3)


def test_batched_over_runs_equals_one_by_one():
    test, _ = _test()
    a = np.stack([test.angle[:360], test.angle[360:]])
    r = np.stack([test.reading[:360], test.reading[360:]])
    both = circular_deviation(a, r, 100.0)
    for k in range(2):
        one = circular_deviation(a[k], r[k], 100.0)
        assert abs(both["G"][k] - one["G"][0]) < 1e-12
