"""cov(e) from repeated SAMBA campaigns (issue 25): the between-campaign scatter of the
residual field, recovered from simulated campaigns with a known cov(e); a stable error
field is in the within-campaign estimate only; the command and its refusals."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.errors import InputError
from mtmetrology.omm.unexplained import load_unexplained_covariance
from mtmetrology.samba import read_records, simulate_records, unexplained_from_campaigns
from mtmetrology.samba.campaign_unexplained import CampaignUnexplained

from .samba_helpers import EXAMPLES, MACHINE, NOISE

UM = 1e-3
#: the true cov(e), µm²: eq. 6-15 of Sepahi Boroujeni (2021) with the XZ term made PSD
TRUE_E = np.array([[45.0, -17.0, 5.0], [-17.0, 66.0, 7.0], [5.0, 7.0, 58.0]])
K = 6


def _campaigns(tmp, machine13, truth13, balls, programme, artefact, *, fixed: bool, seed):
    """K campaign files of the example test (111 indications, 0.5 µm noise); each
    indication's reading moved by A⁻¹ e so that the compensated position is off by e,
    e ~ N(0, TRUE_E) drawn anew per campaign, or once for all (``fixed``)."""
    rng = np.random.default_rng(seed)
    lin = [machine13.axis_names.index(a) for a in machine13.linear_axes]
    field = rng.multivariate_normal(np.zeros(3), TRUE_E * UM**2, size=len(programme))
    paths = []
    for k in range(K):
        path = tmp / f"campaign{k + 1}.csv"
        simulate_records(
            machine13, truth13, balls, programme, artefact, noise=NOISE, seed=rng.integers(2**31)
        ).write(path)
        rec = read_records(path, machine13, artefact)
        e = field if fixed else rng.multivariate_normal(np.zeros(3), TRUE_E * UM**2, len(rec))
        a = machine13.axis_jacobian(rec.readings, truth13)[:, :, lin]
        q = rec.readings.copy()
        q[:, lin] += np.linalg.solve(a, e[..., None])[..., 0]
        cust = machine13.readings_to_customary(q)
        rows = ["ball," + ",".join(machine13.axis_names)]
        rows += [
            ",".join([b, *(f"{v:.9f}" for v in r)]) for b, r in zip(rec.balls, cust, strict=True)
        ]
        path.write_text("\n".join(rows) + "\n", encoding="utf-8")
        paths.append(path)
    return paths


@pytest.fixture(scope="module")
def varying(tmp_path_factory, machine13, truth13, balls, programme, artefact):
    tmp = tmp_path_factory.mktemp("varying")
    paths = _campaigns(tmp, machine13, truth13, balls, programme, artefact, fixed=False, seed=7)
    recs = [read_records(p, machine13, artefact) for p in paths]
    return paths, unexplained_from_campaigns(machine13, recs, artefact, sigma=NOISE)


def test_between_campaign_scatter_recovers_the_true_cov_e(varying):
    """e drawn anew in each of 6 campaigns: ν = (K − 1)(n − p/3) = 5 (111 − 31/3); every
    element of Ĉ_between within 4 of its Wishart standard deviations √((C_ii C_jj +
    C_ij²)/ν) of TRUE_E (P(|z| > 4) = 6e-5 per element), and so is the within estimate."""
    _, res = varying
    assert res.between.degrees_of_freedom == pytest.approx((K - 1) * (111 - 31 / 3))
    assert res.within.degrees_of_freedom == pytest.approx(K * (111 - 31 / 3))
    for est in (res.between, res.within):
        d = np.diag(TRUE_E)
        sd = np.sqrt((np.outer(d, d) + TRUE_E**2) / est.degrees_of_freedom)
        assert np.all(np.abs(est.covariance / UM**2 - TRUE_E) < 4 * sd)
        assert np.linalg.eigvalsh(est.covariance)[0] >= 0


def test_a_stable_error_field_is_within_but_not_between(
    tmp_path, machine13, truth13, balls, programme, artefact
):
    """The same e at every position in every campaign: the between-campaign raw estimate
    is the noise scatter less σ², zero within 4 s.d. (σ² √(2/ν) per diagonal element);
    the within-campaign estimate holds the field (TRUE_E within 4 s.d.)."""
    paths = _campaigns(tmp_path, machine13, truth13, balls, programme, artefact, fixed=True, seed=9)
    recs = [read_records(p, machine13, artefact) for p in paths]
    res = unexplained_from_campaigns(machine13, recs, artefact, sigma=NOISE)
    nu = res.between.degrees_of_freedom
    assert np.all(np.abs(np.diag(res.between.raw)) < 4 * NOISE**2 * np.sqrt(2 / nu))
    d = np.diag(TRUE_E)
    # the within estimate of one field: ν of one campaign (the K copies are not independent)
    sd = np.sqrt((np.outer(d, d) + TRUE_E**2) / (111 - 31 / 3))
    assert np.all(np.abs(res.within.covariance / UM**2 - TRUE_E) < 4 * sd)


def test_document_round_trip_and_the_task_loader(varying, tmp_path):
    _, res = varying
    doc = json.loads(json.dumps(res.to_dict()))
    back = CampaignUnexplained.from_dict(doc)
    np.testing.assert_allclose(back.between.covariance, res.between.covariance, rtol=1e-12)
    np.testing.assert_allclose(back.within.raw, res.within.raw, rtol=1e-12)
    np.testing.assert_allclose(back.residuals, res.residuals, rtol=1e-12)
    assert back.campaigns == res.campaigns and back.fitted_parameters == 31
    path = tmp_path / "E.json"
    path.write_text(json.dumps(doc), encoding="utf-8")
    np.testing.assert_allclose(load_unexplained_covariance(path), res.between.covariance)


def test_fewer_than_two_campaigns_or_another_test_are_refused(varying, machine13, artefact):
    paths, _ = varying
    first = read_records(paths[0], machine13, artefact)
    with pytest.raises(InputError, match="at least 2 campaign files, got 1"):
        unexplained_from_campaigns(machine13, [first], artefact, sigma=NOISE)
    lines = paths[1].read_text().splitlines()
    lines[3], lines[4] = lines[4], lines[3]  # two indications swapped
    other = paths[0].parent / "swapped.csv"
    other.write_text("\n".join(lines) + "\n", encoding="utf-8")
    swapped = read_records(other, machine13, artefact)
    with pytest.raises(InputError, match=r"swapped.csv, line 4: indication 3 .* line 4"):
        unexplained_from_campaigns(machine13, [first, swapped], artefact, sigma=NOISE)


def _cli(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def test_command_writes_the_library_estimate_and_refuses_bad_input(varying, tmp_path):
    paths, res = varying
    out = tmp_path / "E.json"
    common = ["--machine", MACHINE, "--model", "13", "--artefact", EXAMPLES / "artefact.yaml"]
    result = _cli("samba", "unexplained", *paths, *common, "--noise-um", "0.5", "-o", out)
    assert result.exit_code == 0, result.output
    doc = json.loads(out.read_text(encoding="utf-8"))
    assert doc["kind"] == "unexplained-volumetric-error"
    np.testing.assert_allclose(load_unexplained_covariance(out), res.between.covariance)
    bad = tmp_path / "never.json"
    result = _cli("samba", "unexplained", paths[0], *common, "-o", bad)
    assert result.exit_code == 2 and "at least 2 campaign files" in result.output
    assert not bad.exists()
