"""Issue 30's acceptance test of the model-adequacy rule on sequential multilateration.

The issue's set-up: 4 stations, a 5 × 5 × 4 grid over the travel, three non-parallel
reflector offsets (the default tools), the LaserTRACER spec U(k=2) = 0.2 µm + 0.3 µm/m as
the weights.  Each virtual set-up draws fresh machine errors and fresh length noise.

- Noise twice the spec (0.4 µm + 0.6 µm/m): the engine's rule scales the covariance by s²
  (≈ 4); the held-out error at one random point per set-up lies within the scaled 2u (one
  component per set-up, cycled x, y, z) in a count that must lie in the central 99 %
  region of Binomial(N, 0.9545); its d² = (ê − e)ᵀ Σ⁻¹ (ê − e) ≤ χ²₃(0.95) in a count in
  that of Binomial(N, 0.95).  With the a-priori covariance the coverage of 2u is about
  68 % (u half the truth), far below the region.
- Noise as specified: the test does not reject (p ≥ 0.01) in ≥ 95 % of the set-ups
  (99 % expected), so the covariance stays a-priori.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import stats

from mtmetrology.kinematics import Machine
from mtmetrology.multilateration.problem import parse_spec
from mtmetrology.multilateration.requests import pose_grid, reflector_tools
from mtmetrology.multilateration.workflow import (
    MultilaterationResult,
    Station,
    calibrate_multilateration,
    map_monte_carlo,
    simulate_lengths,
)

M = Machine.load("three-axis-xfyz")
STATIONS = [
    Station("S1", (750.0, 50.0, 30.0), 100.0),
    Station("S2", (1250.0, 60.0, 40.0), 200.0),
    Station("S3", (760.0, 560.0, 20.0), 300.0),
    Station("S4", (1240.0, 540.0, 50.0), 400.0),
]
UM = np.array([u == "µm" for u in M.parameter_units])
POSES = pose_grid(M, (5, 5, 4))
TOOLS = reflector_tools(M)
SPEC = parse_spec("0.2um+0.3um/m")
DOUBLE = parse_spec("0.4um+0.6um/m")
N_SETUPS = 60


def _setup(k, noise):
    """Fresh errors (3 µm / 5 µrad, 1 sigma) and fresh noise; the fit weighted by SPEC."""
    rng = np.random.default_rng([30, k])
    theta = rng.normal(size=M.n_params) * np.where(UM, 3e-3, 5e-6)
    record = simulate_lengths(M, theta, STATIONS, POSES, TOOLS, spec=noise, seed=rng)
    return rng, theta, record, calibrate_multilateration(M, record, spec=SPEC)


def _held_out(rng, theta, result):
    """Error of the compensation at one random point: ê − e and its covariance G Σ Gᵀ."""
    point = rng.uniform([800.0, 100.0, 100.0], [1200.0, 500.0, 300.0], (1, 3))
    q = M.inverse(point, np.zeros((1, 3)))
    # the identified model: the preset's plus the constants the reflector offsets expose
    m = result.parameters.machine_for(M)
    ev = m.evaluate(q, result.parameters.vector_for(m), d_params=True)
    miss = (M.forward(q, theta) - ev.position)[0]
    g = ev.d_params[0]
    return miss, g @ result.parameters.covariance @ g.T


def test_noise_twice_the_spec_scaled_2u_covers_held_out_points():
    in_2u = in_region = 0
    for k in range(N_SETUPS):
        rng, theta, _, res = _setup(k, DOUBLE)
        assert res.adequacy.significant and res.adequacy.scaled
        assert res.adequacy.factor == pytest.approx(4.0, rel=0.25)
        miss, cov = _held_out(rng, theta, res)
        c = k % 3
        in_2u += abs(miss[c]) <= 2.0 * np.sqrt(cov[c, c])
        in_region += miss @ np.linalg.solve(cov, miss) <= stats.chi2.ppf(0.95, 3)
    lo, hi = stats.binom.interval(0.99, N_SETUPS, stats.norm.cdf(2.0) - stats.norm.cdf(-2.0))
    assert lo <= in_2u <= hi, (in_2u, lo, hi)
    lo, hi = stats.binom.interval(0.99, N_SETUPS, 0.95)
    assert lo <= in_region <= hi, (in_region, lo, hi)


def test_noise_as_specified_leaves_the_covariance_a_priori():
    kept = 0
    for k in range(N_SETUPS):
        _, _, _, res = _setup(1000 + k, SPEC)
        kept += not res.adequacy.scaled
        assert (res.adequacy.p_value >= 0.01) == (not res.adequacy.scaled)
    assert kept >= 0.95 * N_SETUPS, kept


def test_a_priori_option_keeps_the_covariance_and_the_document_says_so():
    """Same lengths, rule "a-priori": same estimate, covariance smaller by s², the
    document records rule, s², ν, p, scaled, factor and message; patterns by station/tool."""
    _, _, record, scaled = _setup(0, DOUBLE)
    kept = calibrate_multilateration(M, record, spec=SPEC, adequacy="a-priori")
    np.testing.assert_allclose(kept.parameters.values, scaled.parameters.values, rtol=1e-12)
    np.testing.assert_allclose(
        scaled.parameters.covariance, kept.parameters.covariance * scaled.adequacy.factor,
        rtol=1e-10,
    )  # fmt: skip
    doc = kept.to_dict()["provenance"]["adequacy"]
    assert doc["rule"] == "a-priori" and doc["significant"] and not doc["scaled"]
    unknowns = len(kept.parameters.names) + 16  # the model (with the exposed constants), stations
    assert doc["factor"] == 1.0 and doc["dof"] == len(record.lengths) - unknowns
    assert doc["variance_factor"] == pytest.approx(scaled.variance_factor, rel=1e-12)
    back = MultilaterationResult.from_dict(json.loads(json.dumps(scaled.to_dict())), M)
    assert back.adequacy == scaled.adequacy and back.covariance_factor == scaled.adequacy.factor
    patterns = scaled.to_dict()["provenance"]["residual_patterns"]
    assert [g["group"] for g in patterns["station"]] == ["S1", "S2", "S3", "S4"]
    assert len(patterns["tool"]) == 3
    # twice the stated noise everywhere: every group's weighted RMS is near 2
    for group in patterns["station"] + patterns["tool"]:
        assert 1.6 < group["rms_weighted"] < 2.4


def test_map_monte_carlo_draws_the_noise_the_scaled_covariance_stands_for():
    """After scaling, the Monte Carlo re-solves with u·s: its u agrees with the scaled GUF."""
    rng, _, record, res = _setup(1, DOUBLE)
    pts = rng.uniform([800.0, 100.0, 100.0], [1200.0, 500.0, 300.0], (3, 3))
    mc = map_monte_carlo(M, record, res, pts, trials=400, seed=2)
    assert mc.failed == 0
    # sd of a 400-trial standard deviation is 3.5 %: 15 % is over 4 of them
    assert mc.largest_ratio_deviation < 0.15
