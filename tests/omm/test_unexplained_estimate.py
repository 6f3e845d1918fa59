"""cov(e) from data (issue 25): the estimator of :mod:`mtmetrology.uncertainty.unexplained_estimate`
on hand values and on a virtual SAMBA test with a known unmodelled error."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.omm.unexplained import load_unexplained_covariance
from mtmetrology.samba import (
    calibrate,
    load_artefact,
    load_balls,
    read_poses,
    read_records,
    simulate_records,
)
from mtmetrology.uncertainty.unexplained_estimate import (
    UnexplainedCovariance,
    estimate_unexplained_covariance,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "samba"
UM = 1e-3
NOISE = 0.5 * UM
#: the true cov(e), µm²: eq. 6-15 with the XZ term made PSD (digest 000, §3.11)
TRUE_E = np.array([[45.0, -17.0, 5.0], [-17.0, 66.0, 7.0], [5.0, 7.0, 58.0]])
REPLICATES = 40


def test_hand_example_dof_noise_and_mean():
    """Four residuals, p = 3 fitted parameters: ν = 4 − 1 = 3; Σ r rᵀ = diag(2, 8, 0) µm²;
    Σ_v = 0.1 µm² I removed; the z eigenvalue −0.1 is clipped to 0."""
    r = np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 2.0, 0], [0, -2.0, 0]]) * UM
    e = estimate_unexplained_covariance(
        r, fitted_parameters=3, noise_covariance=0.1 * UM**2 * np.eye(3)
    )
    assert e.degrees_of_freedom == 3.0
    np.testing.assert_allclose(np.diag(e.raw) / UM**2, [2 / 3 - 0.1, 8 / 3 - 0.1, -0.1])
    np.testing.assert_allclose(np.diag(e.covariance) / UM**2, [2 / 3 - 0.1, 8 / 3 - 0.1, 0.0])
    assert e.clipped
    centred = estimate_unexplained_covariance(r + 1.0 * UM, centred=True)
    assert centred.degrees_of_freedom == 3.0
    np.testing.assert_allclose(centred.mean, [UM, UM, UM])
    np.testing.assert_allclose(np.diag(centred.covariance) / UM**2, [2 / 3, 8 / 3, 0.0])


def test_clipping_is_the_nearest_psd_matrix():
    """Eigenvalue clipping gives the Frobenius-nearest PSD matrix (Higham 1988): no random
    PSD matrix is closer to the raw estimate than the clipped one."""
    rng = np.random.default_rng(6)
    r = rng.normal(size=(20, 3)) * UM
    e = estimate_unexplained_covariance(r, noise_covariance=np.diag([0.0, 0.0, 5.0]) * UM**2)
    assert e.clipped
    assert np.linalg.eigvalsh(e.covariance)[0] >= -1e-15
    best = np.linalg.norm(e.raw - e.covariance)
    for _ in range(200):
        g = rng.normal(size=(3, 3)) * UM
        candidate = e.covariance + 0.05 * g @ g.T
        assert np.linalg.norm(e.raw - candidate) > best


def test_bad_inputs_name_the_field():
    with pytest.raises(InputError, match="residuals: expected an"):
        estimate_unexplained_covariance(np.zeros((4, 2)))
    with pytest.raises(InputError, match="no degrees of freedom"):
        estimate_unexplained_covariance(np.zeros((4, 3)), fitted_parameters=12)
    with pytest.raises(InputError, match="noise_covariance"):
        estimate_unexplained_covariance(np.zeros((4, 3)), noise_covariance=np.eye(2))


def _perturbed_calibrations(tmp: Path, replicates: int):
    """The example SAMBA test (111 indications, 0.5 µm noise) on a virtual machine with an
    unmodelled volumetric error e_s ~ N(0, TRUE_E) independent per position: the reading
    is moved by A_s⁻¹ e_s so that the compensated position is off by e_s."""
    m = Machine.load("five-axis-wcbxfzyst", "13")
    art = load_artefact(EXAMPLES / "artefact.yaml")
    truth = ParameterSet.load(EXAMPLES / "truth.json", m).vector_for(m)
    balls = load_balls(EXAMPLES / "balls.yaml").centres()
    programme = read_poses(EXAMPLES / "poses.csv")
    rng = np.random.default_rng(2525)
    lin = [m.axis_names.index(a) for a in m.linear_axes]
    for k in range(replicates):
        path = tmp / f"records{k}.csv"
        simulate_records(
            m, truth, balls, programme, art, noise=NOISE, seed=rng.integers(2**31)
        ).write(path)
        rec = read_records(path, m, art)
        a = m.axis_jacobian(rec.readings, truth)[:, :, lin]
        e = rng.multivariate_normal(np.zeros(3), TRUE_E * UM**2, size=len(rec))
        readings = rec.readings.copy()
        readings[:, lin] += np.linalg.solve(a, e[..., None])[..., 0]
        yield m, calibrate(m, dataclasses.replace(rec, readings=readings), art, sigma=NOISE)


@pytest.fixture(scope="module")
def estimates(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("unexplained")
    out = []
    for _, cal in _perturbed_calibrations(tmp, REPLICATES):
        p = len(cal.identification.estimate)
        r = cal.residual_vectors
        out.append(
            (
                estimate_unexplained_covariance(
                    r, fitted_parameters=p, noise_covariance=NOISE**2 * np.eye(3)
                ),
                r.T @ r / len(r),  # the plain mean square, no degrees-of-freedom correction
            )
        )
    return out


def test_estimate_recovers_the_true_unmodelled_error(estimates):
    """Mean of 40 estimates (ν ≈ 100.7 each): every element within 4 s.e. of TRUE_E
    (s.e. of the mean = √((C_ii C_jj + C_ij²)/ν)/√40, Wishart); the trace ratio within
    3 s.e. of 1 (s.e. √(2 tr C²/ν)/tr C/√40 ≈ 0.013)."""
    est = np.array([e.covariance for e, _ in estimates]) / UM**2
    nu = estimates[0][0].degrees_of_freedom
    assert nu == pytest.approx(111 - 31 / 3)
    d = np.diag(TRUE_E)
    se = np.sqrt((np.outer(d, d) + TRUE_E**2) / nu / REPLICATES)
    assert np.all(np.abs(est.mean(axis=0) - TRUE_E) < 4 * se)
    se_ratio = np.sqrt(2 * np.trace(TRUE_E @ TRUE_E) / nu) / np.trace(TRUE_E)
    ratio = np.trace(est.mean(axis=0)) / np.trace(TRUE_E)
    assert abs(ratio - 1) < 3 * se_ratio / np.sqrt(REPLICATES)


def test_without_the_dof_correction_the_estimate_is_biased_low(estimates):
    """The plain mean square Σ r rᵀ / n of fitted residuals falls short by (n − p/3)/n =
    0.907: its trace ratio is within 3 s.e. of 0.907 and more than 3 s.e. below 1."""
    plain = np.array([m for _, m in estimates]) / UM**2
    nu = estimates[0][0].degrees_of_freedom
    se = np.sqrt(2 * np.trace(TRUE_E @ TRUE_E) / nu) / np.trace(TRUE_E) / np.sqrt(REPLICATES)
    ratio = np.trace(plain.mean(axis=0) - NOISE**2 / UM**2 * np.eye(3)) / np.trace(TRUE_E)
    assert abs(ratio - nu / 111) < 3 * se
    assert ratio < 1 - 3 * se


def test_document_round_trip_and_the_task_loader(estimates, tmp_path):
    """to_dict → from_dict is lossless; the file is what ``mtm task uncertainty
    --unexplained`` reads (same matrix, mm²)."""
    e = estimates[0][0]
    doc = e.to_dict()
    back = UnexplainedCovariance.from_dict(json.loads(json.dumps(doc)))
    np.testing.assert_allclose(back.covariance, e.covariance, rtol=1e-12)
    np.testing.assert_allclose(back.raw, e.raw, rtol=1e-12)
    assert back.degrees_of_freedom == e.degrees_of_freedom
    path = tmp_path / "E.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    np.testing.assert_allclose(load_unexplained_covariance(path), e.covariance, rtol=1e-12)


def test_calibrate_samba_writes_the_unexplained_document(tmp_path):
    """``mtm samba calibrate --unexplained-out E.json`` on records with the unmodelled
    error: the file has ν = n − p/3 and its matrix equals the library estimate."""
    m, cal = next(_perturbed_calibrations(tmp_path, 1))
    path = tmp_path / "perturbed.csv"
    rows = ["ball,X,Y,Z,B,C,S"]
    r = m.readings_to_customary(cal.records.readings)
    for b, row in zip(cal.records.balls, r, strict=True):
        rows.append(",".join([b, *(f"{v:.9f}" for v in row)]))
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    out = tmp_path / "E.json"
    result = CliRunner().invoke(
        app,
        [
            "samba",
            "calibrate",
            str(path),
            "--machine",
            "five-axis-wcbxfzyst",
            "--model",
            "13",
            "--artefact",
            str(EXAMPLES / "artefact.yaml"),
            "--noise-um",
            "0.5",
            "--unexplained-out",
            str(out),
        ],
    )
    assert result.exit_code == 0, result.output
    doc = json.loads(out.read_text(encoding="utf-8"))
    assert doc["kind"] == "unexplained-volumetric-error"
    assert doc["estimate"]["degrees_of_freedom"] == pytest.approx(111 - 31 / 3)
    expected = estimate_unexplained_covariance(
        cal.residual_vectors, fitted_parameters=31, noise_covariance=NOISE**2 * np.eye(3)
    )
    np.testing.assert_allclose(
        load_unexplained_covariance(out), expected.covariance, rtol=1e-6, atol=1e-12
    )
