"""Tests for ``mtm repeatability fit`` (mtmetrology.cli.repeatability)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app

runner = CliRunner()
HEADER = "target,phi,theta,B,C,X_T,Y_T,Z_T,i,j,k,X,Y,Z,time"


def _csv(tmp_path, n_targets=45, touches=6, seed=0, mutate=None):
    rng = np.random.default_rng(seed)
    rows = [HEADER]
    for t in range(n_targets):
        phi, theta = rng.uniform(0, 90), rng.uniform(0, 360)
        b, c = rng.uniform(-90, 90), rng.uniform(-180, 180)
        x, y, z = rng.uniform(-200, 200, 3)
        n = [
            np.sin(np.radians(phi)) * np.sin(np.radians(theta)),
            np.sin(np.radians(phi)) * np.cos(np.radians(theta)),
            np.cos(np.radians(phi)),
        ]
        for s in range(touches):
            p = np.array([x, y, z]) + rng.normal(0, 0.001, 3)
            rows.append(
                f"T{t},{phi},{theta},{b},{c},{x},{y},{z},{-n[0]},{-n[1]},{-n[2]},"
                f"{p[0]:.6f},{p[1]:.6f},{p[2]:.6f},{s}"
            )
    if mutate:
        rows = mutate(rows)
    path = tmp_path / "records.csv"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_fit_writes_model_document_and_report(tmp_path):
    out, rep = tmp_path / "R.json", tmp_path / "R.html"
    result = runner.invoke(
        app,
        [
            "repeatability", "fit", str(_csv(tmp_path)), "-o", str(out), "--report", str(rep),
            "--allow-few-targets",
        ],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    doc = json.loads(out.read_text(encoding="utf-8"))
    assert doc["kind"] == "repeatability-model" and doc["version"] == 1
    assert doc["n_fit"] + doc["n_validation"] == 45 and doc["n_validation"] == 7
    assert len(doc["statistics"]["targets"]) == 45
    assert all(t["n_touches"] == 5 for t in doc["statistics"]["targets"])
    sx = next(o for o in doc["outputs"] if o["name"] == "sigma_X")
    # Readings scatter with σ = 1 µm: the fitted constant term is about 1 µm.
    assert sx["unit"] == "µm" and 0.7 < sx["coefficients"][0] < 1.3
    assert rep.read_text(encoding="utf-8").lstrip().lower().startswith("<!doctype html")


def test_help_documents_the_columns():
    result = runner.invoke(app, ["repeatability", "fit", "--help"])
    assert result.exit_code == 0
    for column in ("phi", "theta", "X_T", "time", "i, j, k"):
        assert column in result.output


def _drop_column_x(rows):
    return [",".join(r.split(",")[:11] + r.split(",")[12:]) for r in rows]


def _zero_approach(rows):
    f = rows[3].split(",")
    f[8:11] = ["0", "0", "0"]
    return [*rows[:3], ",".join(f), *rows[4:]]


def _text_reading(rows):
    f = rows[5].split(",")
    f[12] = "abc"
    return [*rows[:5], ",".join(f), *rows[6:]]


@pytest.mark.parametrize(
    ("kwargs", "args", "named"),
    [
        # too few targets for eq. 4-2
        ({"n_targets": 30}, [], "30 targets (4 held out): the covariance model (eq. 4-2)"),
        # 2 usable touches per target
        ({"touches": 3}, [], "{path}: target 'T0' has 2 usable touches"),
        ({"mutate": _drop_column_x}, [], "{path}: missing column 'X'"),
        ({"mutate": _zero_approach}, [], "{path}, line 4: the approach (i, j, k) is the zero"),
        ({"mutate": _text_reading}, [], "{path}, line 6: column 'Y' holds 'abc', not a number"),
        ({}, ["--holdout", "1.5"], "holdout: must be in [0, 1), got 1.5"),
        # 38 fitting targets for 36 coefficients, without --allow-few-targets
        ({}, [], "45 targets (7 held out): 38 fitting targets for the 36 coefficients"),
    ],
    ids=["targets", "touches", "column", "approach", "text", "holdout", "sparse"],
)
def test_bad_input_exits_2_naming_the_file_line_and_field(tmp_path, kwargs, args, named):
    out = tmp_path / "R.json"
    rep = tmp_path / "R.html"
    path = _csv(tmp_path, **kwargs)
    result = runner.invoke(
        app, ["repeatability", "fit", str(path), "-o", str(out), "--report", str(rep), *args]
    )
    assert result.exit_code == 2
    lines = (
        result.stderr.strip().splitlines() if result.stderr else result.output.strip().splitlines()
    )
    assert len(lines) == 1 and lines[0].startswith("error: " + named.format(path=path)), lines
    assert not out.exists() and not rep.exists()


def test_sparse_model_is_refused_unless_asked_and_held_out_errors_are_reported(tmp_path):
    """36 coefficients fitted on 38 targets were written with "written" only (issue 18 §3).
    Refused by default, naming the count and the option; with --allow-few-targets the
    held-out error of every output is printed and stored, and those above the stated 50 %
    are flagged: cov(X,Y) at least, zero here (the readings scatter independently)."""
    path, out = _csv(tmp_path), tmp_path / "R.json"
    refused = runner.invoke(app, ["repeatability", "fit", str(path), "-o", str(out)])
    assert refused.exit_code == 2 and not out.exists()
    assert "38 fitting targets for the 36 coefficients" in refused.output
    assert refused.output.rstrip().endswith("(--allow-few-targets)")
    result = runner.invoke(
        app, ["repeatability", "fit", str(path), "-o", str(out), "--allow-few-targets"]
    )
    assert result.exit_code == 0, result.output
    doc = json.loads(out.read_text(encoding="utf-8"))
    assert doc["validation_warning"] == 0.5
    flagged = {o["name"] for o in doc["outputs"] if o["validation_flagged"]}
    assert flagged == {
        o["name"] for o in doc["outputs"] if o["validation_rms_relative_error"] > 0.5
    }
    assert "cov_XY" in flagged
    rows = {ln.split()[0]: ln.split() for ln in result.stdout.splitlines() if ln.startswith("  ")}
    assert list(rows)[1:] == [o["name"] for o in doc["outputs"]]  # header, then each output
    for o in doc["outputs"]:
        assert rows[o["name"]][-1] == ("flagged" if o["name"] in flagged else "%")
    warning = [ln for ln in result.stderr.splitlines() if ln.startswith("warning: held-out")]
    assert len(warning) == 1 and all(name in warning[0] for name in flagged)


def test_enough_targets_fit_without_the_option(tmp_path):
    """128 targets, 15 % held out: 109 fitting targets, at least 3 per coefficient."""
    out = tmp_path / "R.json"
    result = runner.invoke(
        app, ["repeatability", "fit", str(_csv(tmp_path, n_targets=128)), "-o", str(out)]
    )
    assert result.exit_code == 0, result.output
    assert json.loads(out.read_text(encoding="utf-8"))["n_fit"] == 109
