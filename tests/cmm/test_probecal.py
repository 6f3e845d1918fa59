"""Stylus offsets and plate as unknowns, with qualification records (Salacheep 2016, §4.5)."""

from __future__ import annotations

import numpy as np
import pytest
from cmm_virtual import SIGMA, TRAIN, make_plate, make_positions

from mtmetrology.cmm.calibrate import model_machine
from mtmetrology.cmm.files import BallPlateRecords, ProbeSet
from mtmetrology.cmm.probecal import CalibratedLength, ProbeCalibration, calibrate_with_probes
from mtmetrology.cmm.simulate import simulate_ballplate
from mtmetrology.errors import InputError, RankDeficientError

NOMINAL = {"P0": [0, 0, -150], "PX1": [50, 0, -150], "PX2": [-50, 0, -150],
           "PY1": [0, 50, -150], "PY2": [0, -50, -150]}  # fmt: skip
SPHERE = np.array([600.0, 500.0, 300.0])


def _probes(d):
    return ProbeSet(
        kind="probe-set", probes=[{"id": k, "offset_mm": list(v)} for k, v in d.items()]
    )


@pytest.fixture(scope="module")
def case(base):
    """Seed-model errors, styli off their nominal offsets by ~3 µm, 2 qualifications each."""
    rng = np.random.default_rng(5)
    corr = {k: rng.normal(0, 0.003, 3) for k in NOMINAL}
    true = _probes({k: np.array(v) + corr[k] for k, v in NOMINAL.items()})
    plate = make_plate(3, 266.0)
    machine, _ = model_machine(base, "seed")
    size = np.where([p.is_rotation for p in machine.parameters], 8e-6, 0.004)
    theta = size * rng.standard_normal(machine.n_params)
    camp = simulate_ballplate(
        machine, theta, plate, make_positions(*TRAIN), true, sigma=SIGMA, seed=3,
        perturb_plate=False,
    )  # fmt: skip
    ids = list(NOMINAL) * 2
    t = true.offsets(ids)
    q = machine.inverse(np.tile(SPHERE, (len(ids), 1)), SPHERE - t, theta, tool=t)
    q = q + SIGMA * rng.standard_normal(q.shape)
    qual = BallPlateRecords(
        ("Q",) * len(ids), ("S",) * len(ids), tuple(ids), q, np.arange(len(ids)) + 2
    )
    return camp.records, plate, qual, corr, theta


def _z(res, theta):
    v = np.array([x[0] for x in res.parameters.values()])
    u = np.array([x[1] for x in res.parameters.values()])
    return (v - theta) / u


def test_stylus_offsets_are_recovered_with_the_certificate(base, case):
    """The estimated corrections equal the true ones less their centroid (the constraint),
    within 3.5 u each (15 components: P(any outside) ≈ 0.7 % for a correct u)."""
    records, plate, qual, corr, theta = case
    res = calibrate_with_probes(base, records, plate, _probes(NOMINAL), qual, sigma=SIGMA)
    true = np.array([corr[k] for k in res.probes])
    true -= true.mean(axis=0)
    est = np.array([p["correction_um"] for p in res.probes.values()]) / 1e3
    u = np.array([p["u_um"] for p in res.probes.values()]) / 1e3
    np.testing.assert_allclose(est.sum(axis=0), 0.0, atol=1e-9)
    assert np.all(np.abs(est - true) < 3.5 * u)
    assert np.all(np.abs(_z(res, theta)) < 3.5)
    assert 0.8 < res.fit["variance_factor"] < 1.2


def test_plate_self_calibrated_with_one_length(base, case):
    """Balls free but for the diagonal 00–08 (u 0.2 µm): every other plate length comes out
    within 3.5 u of the truth (u from the ball uncertainties, correlations left out: an upper
    bound when they are positive), the error parameters within 3.5 u; the scale errors now
    carry the one length's uncertainty (u > that with the certificate)."""
    records, plate, qual, _, theta = case
    diag = float(np.hypot(532.0, 532.0))
    res = calibrate_with_probes(
        base, records, plate, _probes(NOMINAL), qual, sigma=SIGMA,
        length=CalibratedLength("00", "08", diag, 0.0002),
    )  # fmt: skip
    assert res.plate == "one length 00-08"
    b = np.array([v["xyz_mm"] for v in res.balls.values()])
    y = plate.coordinates
    d_est = np.linalg.norm(b[:, None] - b[None], axis=-1)
    d_true = np.linalg.norm(y[:, None] - y[None], axis=-1)
    bu = np.array([v["u_um"] for v in res.balls.values()]) / 1e3
    g = (y[:, None] - y[None]) / np.where(d_true > 0, d_true, 1.0)[..., None]
    u_d = np.sqrt(
        np.sum(g**2 * (bu[:, None] ** 2 + bu[None] ** 2), axis=-1)
    )  # correlations left out
    off = ~np.eye(len(y), dtype=bool)
    assert np.all(np.abs(d_est - d_true)[off] < 3.5 * u_d[off])
    assert np.all(np.abs(_z(res, theta)) < 3.5)
    cert = calibrate_with_probes(base, records, plate, _probes(NOMINAL), qual, sigma=SIGMA)
    assert res.parameters["E_XX1"][1] > cert.parameters["E_XX1"][1]


def test_round_trip_and_missing_qualification(base, case):
    records, plate, qual, _, _ = case
    res = calibrate_with_probes(base, records, plate, _probes(NOMINAL), qual, sigma=SIGMA)
    assert ProbeCalibration.from_dict(res.to_dict()).to_dict() == res.to_dict()
    keep = np.array([p != "PY2" for p in qual.probes])
    with pytest.raises(InputError, match="no record of stylus PY2"):
        calibrate_with_probes(base, records, plate, _probes(NOMINAL), qual.subset(keep),
                              sigma=SIGMA)  # fmt: skip


def test_a_plate_seen_in_one_plane_is_refused_with_the_free_combination_named(base, case):
    """Self-calibrated plate, horizontal position only: the z scale (and more) is free; the
    refusal names the error parameters involved."""
    records, plate, qual, _, _ = case
    horizontal = records.subset(np.array([p == "H" for p in records.positions]))
    with pytest.raises(RankDeficientError) as err:
        calibrate_with_probes(
            base, horizontal, plate, _probes(NOMINAL), qual, sigma=SIGMA,
            length=CalibratedLength("00", "08", float(np.hypot(532.0, 532.0)), 0.0002),
        )  # fmt: skip
    names = {n for group in err.value.confounded for n in group}
    assert "E_ZZ1" in names
