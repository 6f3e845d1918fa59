"""Tests for ``mtm samba long-term`` (mtmetrology.cli.long_term)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.io import write_json
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet

runner = CliRunner()
MACHINE = Machine.load("five-axis-wcbxfzyst")
SCALES = MACHINE.parameter_scales


def _write(tmp_path, n=3, **overrides):
    rng = np.random.default_rng(8)
    values = rng.normal(size=(n, 13)) * SCALES * 5
    paths = []
    for k, v in enumerate(values):
        path = tmp_path / f"cal{k + 1}.json"
        ParameterSet(
            MACHINE.parameter_names,
            v,
            MACHINE.parameter_units,
            np.diag((SCALES * 0.5) ** 2),
            machine=MACHINE.name,
            model="13",
        ).save(path)
        paths.append(str(path))
    return paths, values


def test_written_document_round_trips_through_parameter_set_load(tmp_path):
    paths, values = _write(tmp_path)
    out = tmp_path / "lt.json"
    result = runner.invoke(app, ["samba", "long-term", *paths, "-o", str(out), "--json"])
    assert result.exit_code == 0, result.output
    printed = json.loads(result.stdout)
    assert printed["kind"] == "parameter-set" and printed["provenance"]["calibrations"] == 3
    loaded = ParameterSet.load(out, MACHINE)
    assert loaded.names == MACHINE.parameter_names and loaded.model == "13"
    assert np.allclose(loaded.values, values[-1], rtol=1e-12, atol=0)
    assert np.allclose(loaded.covariance, np.cov(values.T, ddof=1), rtol=1e-9, atol=0)
    assert printed["provenance"]["sources"] == paths


def test_mean_values_and_within_covariance_options(tmp_path):
    paths, values = _write(tmp_path)
    out = tmp_path / "lt.json"
    argv = ["samba", "long-term", *paths, "-o", str(out), "--values", "mean", "--add-within"]
    result = runner.invoke(app, argv)
    assert result.exit_code == 0, result.output
    loaded = ParameterSet.load(out, MACHINE)
    assert np.allclose(loaded.values, values.mean(axis=0), rtol=1e-12, atol=1e-15)
    # the console states u by name, not as "value ± u" (read as U; issue 18 §3)
    printed = [ln.split() for ln in result.stdout.splitlines() if ln.startswith("  ")]
    assert [r[0] for r in printed] == list(MACHINE.parameter_names)
    assert all(r[3:5] == ["u", "="] and r[2] == r[6] for r in printed)
    expected = np.cov(values.T, ddof=1) + np.diag((SCALES * 0.5) ** 2)
    assert np.allclose(loaded.covariance, expected, rtol=1e-9, atol=0)


def _other_machine(tmp_path, paths):
    doc = json.loads(open(paths[1], encoding="utf-8").read())
    doc["machine"] = "three-axis-xyz"
    write_json(paths[1], doc)


def _other_names(tmp_path, paths):
    doc = json.loads(open(paths[1], encoding="utf-8").read())
    doc["parameters"] = doc["parameters"][:12]
    doc["covariance"] = None
    write_json(paths[1], doc)


@pytest.mark.parametrize(
    "spoil",
    [lambda tmp, paths: paths.pop(), _other_machine, _other_names],
    ids=["one-file", "other-machine", "other-parameters"],
)
def test_refusals_exit_2_and_write_nothing(tmp_path, spoil):
    paths, _ = _write(tmp_path, n=2)
    spoil(tmp_path, paths)
    out = tmp_path / "lt.json"
    result = runner.invoke(app, ["samba", "long-term", *paths, "-o", str(out)])
    assert result.exit_code == 2, result.output
    assert result.stderr.startswith("error: ")
    assert len(result.stderr.strip().splitlines()) == 1
    assert not out.exists()
