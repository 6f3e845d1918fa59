"""``--model auto``: an information criterion checked against held-out plate positions.

A virtual bridge CMM whose true errors include third-degree straightness (so ``full-3``
is the true degree) is calibrated on five plate positions with three styli; the candidates
are then judged on two other positions against the truth (length errors of every ball pair).
Before issue 18 the choice was the lowest *mean* leave-one-position-out RMS, which one fold
of ``full-3`` (the tilted plate T left out: about 400–1 200 µm) decided: ``full-2`` was
chosen with a held-out error 36–40 % above ``full-3``'s at these seeds.  Over seeds 3–12 of
this set-up the rule now chooses ``full-3`` each time (bench: none; seeds fixed here).
"""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.cmm import BallPlate, PositionSet, ProbeSet, simulate_ballplate
from mtmetrology.cmm.calibrate import (
    ABSURD_FACTOR,
    CHECK_FACTOR,
    calibrate_ballplate,
    cross_validate,
)
from mtmetrology.cmm.compare import length_errors
from mtmetrology.cmm.models import machine_for_model, parse_model
from mtmetrology.kinematics import Machine
from mtmetrology.units import from_internal, to_internal

SIGMA = 0.0005
CANDIDATES = ["seed", "full-1", "full-2", "full-3"]
TRUTH = {  # the seed model's terms and third-degree straightness (Chebyshev, µm / µrad)
    "E_XX1": ("µm", 6.0), "E_YY1": ("µm", -4.0), "E_ZZ1": ("µm", 3.0),
    "E_BY2": ("µrad", 6.0), "E_CX1": ("µrad", 8.0), "E_AZ1": ("µrad", -5.0),
    "E_C0X": ("µrad", 10.0), "E_YX2": ("µm", 2.0), "E_XY2": ("µm", -2.0),
    "E_YX3": ("µm", 3.0), "E_ZX3": ("µm", -2.5), "E_XY3": ("µm", 2.5),
    "E_ZY3": ("µm", 2.0), "E_XZ3": ("µm", -2.0), "E_YZ3": ("µm", 1.5),
}  # fmt: skip
STYLI = {"P0": [0, 0, -150], "PX1": [50, 0, -150], "PY1": [0, 50, -150]}
CALIBRATION = [
    ("H", [330, 230, 150], [0, 0, 0]), ("VX", [330, 500, 10], [90, 0, 0]),
    ("VY", [600, 230, 10], [90, 0, 90]), ("T", [330, 230, 120], [30, 0, 0]),
    ("D", [300, 300, 10], [90, 0, 45]),
]  # fmt: skip
HELD_OUT = [("D2", [650, 280, 10], [90, 0, 135]), ("H2", [330, 230, 60], [0, 0, 0])]


def _positions(specs):
    return PositionSet(
        kind="ballplate-positions",
        positions=[
            {"id": i, "origin_mm": o, "rotation_deg": r, "probes": list(STYLI)} for i, o, r in specs
        ],
    )


@pytest.fixture(scope="module")
def setup():
    base = Machine.load("cmm-moving-bridge")
    machine = machine_for_model(base, parse_model("full-3"))
    theta = np.zeros(machine.n_params)
    for name, (unit, value) in TRUTH.items():
        theta[machine.parameter_names.index(name)] = to_internal(value, unit)
    probes = ProbeSet(
        kind="probe-set", probes=[{"id": k, "offset_mm": v} for k, v in STYLI.items()]
    )
    plate = BallPlate(
        kind="ball-plate",
        u_mm=0.0005,
        balls=[
            {"id": f"{3 * j + i:02d}", "x_mm": 266.0 * i, "y_mm": 266.0 * j, "z_mm": 0.0}
            for j in range(3)
            for i in range(3)
        ],
    )
    return base, machine, theta, probes, plate


def _held_out_rms_um(cal, campaign, probes) -> float:
    """RMS length error (µm) of every ball pair per position and stylus, against the truth."""
    rec, errors = campaign.records, []
    tools = probes.offsets(rec.probes)
    for key in dict.fromkeys(zip(rec.positions, rec.probes, strict=True)):
        s = np.array([k == key for k in zip(rec.positions, rec.probes, strict=True)])
        n = int(s.sum())
        pts = cal.compensate(rec.readings[s], tools[s])
        errors.append(length_errors(pts, campaign.true_points[s], np.zeros((3, n, n)), SIGMA)[1])
    return float(from_internal(np.sqrt(np.mean(np.concatenate(errors) ** 2)), "µm"))


@pytest.mark.parametrize("seed", [4, 7])
def test_auto_picks_a_model_within_10_percent_of_the_best_held_out_error(setup, seed):
    base, machine, theta, probes, plate = setup
    cal = simulate_ballplate(
        machine, theta, plate, _positions(CALIBRATION), probes, sigma=SIGMA, seed=seed
    )
    test = simulate_ballplate(
        machine, theta, plate, _positions(HELD_OUT), probes, sigma=SIGMA, seed=seed + 100
    )
    held_out = {
        c: _held_out_rms_um(
            calibrate_ballplate(base, cal.records, plate, probes, model=c, sigma=SIGMA),
            test,
            probes,
        )
        for c in CANDIDATES
    }
    sel = cross_validate(base, cal.records, plate, probes, CANDIDATES, sigma=SIGMA)
    assert held_out[sel["chosen"]] <= 1.10 * min(held_out.values()), (sel["chosen"], held_out)
    # every candidate's scores are reported, structured
    scores = {s["model"]: s for s in sel["scores"]}
    assert list(scores) == CANDIDATES and sel["positions"] == [p[0] for p in CALIBRATION]
    for s in scores.values():
        assert len(s["rms_um"]) == len(s["status"]) == len(CALIBRATION)
        assert s["aic"] is not None and s["median_rms_um"] is not None
    # the fold that extrapolates (full-3 without the tilted plate) is flagged, decides nothing
    t = sel["positions"].index("T")
    assert scores["full-3"]["status"][t] == "absurd" and scores["full-3"]["absurd"]
    assert scores["full-3"]["rms_um"][t] > ABSURD_FACTOR * scores["full-2"]["rms_um"][t]
    assert "T" not in sel["common_folds"]
    chosen = scores[sel["chosen"]]
    best = min(s["median_rms_um"] for s in scores.values() if s["scored"])
    assert chosen["eligible"] and chosen["median_rms_um"] <= CHECK_FACTOR * best
    eligible_aic = [s["aic"] for s in scores.values() if s["eligible"]]
    assert chosen["aic"] == min(eligible_aic)
