"""``mtm samba calibrate --campaign-uncertainty``: K campaign records give u of their mean
(S/K) by default or u of one run (S, the form of Sepahi Boroujeni (2021), Table 5-2,
whose mean of k runs has u/√k); the document says which (``records.uncertainty_of``)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "samba"
K = 5
#: parameters whose u is dominated by the scale bar's (not by the indications)
SCALE = ("E_XX1", "E_YY1", "E_ZZ1")


def mtm(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


@pytest.fixture(scope="module")
def campaigns(tmp_path_factory):
    path = tmp_path_factory.mktemp("campaigns") / "camp.csv"
    result = mtm(
        "samba", "simulate", "--machine", "five-axis-wcbxfzyst", "--model", "13",
        "--truth", EXAMPLES / "truth.json", "--artefact", EXAMPLES / "artefact.yaml",
        "--balls", EXAMPLES / "balls.yaml", "--poses", EXAMPLES / "poses.csv",
        "--noise-um", "0.5", "--campaigns", K, "--seed", "3", "-o", path,
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    return path


def _calibrate(path, *extra):
    return mtm(
        "samba", "calibrate", path, "--machine", "five-axis-wcbxfzyst", "--model", "13",
        "--artefact", EXAMPLES / "artefact.yaml", *extra,
    )  # fmt: skip


def test_one_run_u_is_sqrt_k_times_that_of_the_mean(campaigns):
    """Same estimate; u(one run)/u(mean) = √K for the parameters the indications fix, and
    between 1 and √K where the scale bar's u (not scaled by K) enters."""
    docs = {}
    for which in ("mean", "single"):
        r = _calibrate(campaigns, "--uncertainty", "guf", "--campaign-uncertainty", which, "--json")
        assert r.exit_code == 0, r.output
        docs[which] = json.loads(r.stdout)
    assert docs["mean"]["records"]["uncertainty_of"] == f"mean of {K} campaigns"
    assert docs["single"]["records"]["uncertainty_of"] == "one run"
    for m, s in zip(docs["mean"]["parameters"], docs["single"]["parameters"], strict=True):
        assert m["value"] == s["value"]
        ratio = s["u"] / m["u"]
        if m["name"] in SCALE:
            assert 1.0 < ratio < np.sqrt(K)
        else:
            assert ratio == pytest.approx(np.sqrt(K), rel=1e-3)


def test_default_is_the_mean(campaigns):
    r = _calibrate(campaigns, "--json")
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["records"]["uncertainty_of"] == f"mean of {K} campaigns"


def test_one_run_needs_a_propagation(campaigns, tmp_path):
    out = tmp_path / "R.json"
    r = _calibrate(campaigns, "--campaign-uncertainty", "single", "-o", out)
    assert r.exit_code == 2 and not out.exists()
    assert "--campaign-uncertainty single needs --uncertainty" in r.output
