"""Tests for ``mtm repeatability fit --drift/--window`` and ``mtm repeatability hysteresis``."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app

runner = CliRunner()
HEADER = "target,phi,theta,B,C,X_T,Y_T,Z_T,i,j,k,X,Y,Z,time"


def _records(tmp_path, touches=12, n_targets=40, seed=0):
    """σ = 1 µm white noise on a common cubic drift of X (up to 15 µm) in time."""
    rng = np.random.default_rng(seed)
    rows = [HEADER]
    poses = [
        (rng.uniform(0, 90), rng.uniform(0, 360), rng.uniform(-90, 90), rng.uniform(-180, 180),
         *rng.uniform(-200, 200, 3))
        for _ in range(n_targets)
    ]  # fmt: skip
    span = touches * n_targets
    for cycle in range(touches):
        for t, (phi, theta, b, c, x, y, z) in enumerate(poses):
            time = cycle * n_targets + t
            u = time / span
            drift = 0.015 * (3 * u - 6 * u**2 + 4 * u**3)
            p = np.array([x + drift, y, z]) + rng.normal(0, 0.001, 3)
            rows.append(
                f"T{t},{phi},{theta},{b},{c},{x},{y},{z},0.6,0.0,-0.8,"
                f"{p[0]:.7f},{p[1]:.7f},{p[2]:.7f},{time}"
            )
    path = tmp_path / "records.csv"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def _fit(tmp_path, path, *args):
    out, rep = tmp_path / "R.json", tmp_path / "R.html"
    result = runner.invoke(
        app,
        [
            "repeatability",
            "fit",
            str(path),
            "-o",
            str(out),
            "--report",
            str(rep),
            "--allow-few-targets",
            *args,
        ],
    )
    return result, out, rep


def test_fit_with_cubic_drift_and_sliding_window(tmp_path):
    path = _records(tmp_path, n_targets=45)
    result, out, rep = _fit(tmp_path, path, "--drift", "cubic", "--window", "10", "--holdout", "0")
    assert result.exit_code == 0, result.output
    doc = json.loads(out.read_text(encoding="utf-8"))
    stats = doc["statistics"]
    assert stats["drift"] == {"model": "cubic", "abscissa": "time", "ddof": 4}
    sx = np.array([t["sigma_X"] for t in stats["targets"]])
    sx_raw = np.array([t["sigma_X_raw"] for t in stats["targets"]])
    # Drift removed: σ_X pooled over 45 targets (45·7 dof) is the 1 µm noise (±15 %);
    # the raw σ_X holds the drift (about 2.5 µm) and is larger at every target.
    assert 0.85 < np.sqrt(np.mean(sx**2)) < 1.15
    assert np.all(sx_raw > sx) and np.median(sx_raw / sx) > 2.0
    windows = doc["windows"]
    assert windows["window"] == 10 and windows["first_iteration"] == 2
    assert len(windows["targets"]) == 45
    assert windows["targets"][0]["start"] == [2, 3]  # 12 touches: windows 2–11 and 3–12
    html = rep.read_text(encoding="utf-8")
    assert html.count("<svg") >= 1


def test_fit_without_drift_reports_no_raw_columns(tmp_path):
    result, out, _ = _fit(tmp_path, _records(tmp_path, n_targets=45))
    assert result.exit_code == 0, result.output
    doc = json.loads(out.read_text(encoding="utf-8"))
    assert doc["statistics"]["drift"] == {"model": "none"}
    assert "sigma_X_raw" not in doc["statistics"]["targets"][0] and "windows" not in doc


def _single_error_line(result):
    text = result.stderr if result.stderr else result.output
    lines = text.strip().splitlines()
    return len(lines) == 1 and lines[0].startswith("error: ")


@pytest.mark.parametrize(
    ("touches", "args", "field"),
    [
        (6, ["--drift", "cubic"], "T0"),  # 5 usable touches < 6 for a cubic
        (12, ["--window", "12"], "T0"),  # 11 touches from iteration 2
        (12, ["--window", "10", "--window-from", "4"], "T0"),
    ],
)
def test_bad_drift_or_window_exits_2_and_writes_nothing(tmp_path, touches, args, field):
    result, out, rep = _fit(tmp_path, _records(tmp_path, touches=touches, n_targets=45), *args)
    assert result.exit_code == 2
    assert _single_error_line(result)
    assert f"'{field}'" in (result.stderr or result.output)
    assert not out.exists() and not rep.exists()


def test_unknown_drift_model_and_too_small_window_are_usage_errors(tmp_path):
    path = _records(tmp_path, n_targets=45)
    for args in (["--drift", "linear"], ["--window", "1"]):
        result, out, rep = _fit(tmp_path, path, *args)
        assert result.exit_code == 2
        assert f"Invalid value for '{args[0]}'" in result.output, result.output
        assert not out.exists() and not rep.exists()


# -- hysteresis ------------------------------------------------------------------------
def _ring(tmp_path, *, conditions=("direct", "hysteresis"), cycles=24, columns="xy", seed=1):
    rng = np.random.default_rng(seed)
    head = "psi,condition," + ("X,Y" if columns == "xy" else "r")
    rows, truth = [head], {}
    for _ in range(cycles):
        for psi in range(0, 360, 30):
            a = np.radians(psi)
            for cond, offset in zip(conditions, (0.0, -0.0002), strict=True):
                r = 28.782 + offset + rng.normal(0, 0.0005)
                truth.setdefault((psi, cond), []).append(r)
                values = f"{r * np.cos(a):.9f},{r * np.sin(a):.9f}" if columns == "xy" else f"{r}"
                rows.append(f"{psi},{cond},{values}")
    path = tmp_path / "ring.csv"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path, truth


def test_hysteresis_writes_result_report_and_json(tmp_path):
    path, truth = _ring(tmp_path)
    out, rep = tmp_path / "H.json", tmp_path / "H.html"
    result = runner.invoke(
        app,
        ["repeatability", "hysteresis", str(path), "-o", str(out), "--report", str(rep), "--json"],
    )
    assert result.exit_code == 0, result.output
    doc = json.loads(out.read_text(encoding="utf-8"))
    assert json.loads(result.stdout) == doc
    assert doc["kind"] == "hysteresis-result" and doc["test"] == "probing"
    assert len(doc["outputs"]) == 12
    for row, o in zip(doc["indexations"], doc["outputs"], strict=True):
        with_h, without = (np.array(truth[(row["psi"], c)]) for c in ("hysteresis", "direct"))
        expected = 1000 * (with_h.mean() - without.mean())  # µm
        u = 1000 * np.sqrt(with_h.var(ddof=1) / 24 + without.var(ddof=1) / 24)
        assert o["value"] == pytest.approx(expected, abs=1e-5)  # X, Y printed to 1 nm·1e-3
        assert o["u"] == pytest.approx(u, rel=1e-4)
        assert o["unit"] == "µm" and o["interval"][0] < o["value"] < o["interval"][1]
    assert rep.read_text(encoding="utf-8").count("<svg") >= 1


def test_axis_hysteresis_from_radial_projections(tmp_path):
    path, _ = _ring(tmp_path, conditions=("+", "-"), columns="r")
    result = runner.invoke(app, ["repeatability", "hysteresis", str(path), "--json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["test"] == "axis" and doc["definition"] == "H = mean r (+) - mean r (-)"
    # the "+" rows carry offset 0, the "-" rows −0.2 µm: H ≈ +0.2 µm on average.
    assert doc["summary"]["mean"] == pytest.approx(0.2, abs=4 * doc["summary"]["mean_u"])


def _edit(path, fn):
    lines = path.read_text(encoding="utf-8").splitlines()
    path.write_text("\n".join(fn(lines)) + "\n", encoding="utf-8")


@pytest.mark.parametrize(
    "edit",
    [
        lambda ls: [ls[0], ls[1].replace("direct", "straight"), *ls[2:]],  # unknown label
        lambda ls: [ls[0], ls[1].replace("direct", "+"), *ls[2:]],  # two tests mixed
        lambda ls: [ls[0] + ",r", *(x + ",28.78" for x in ls[1:])],  # r and X, Y
        lambda ls: [ls[0].replace("psi", "angle"), *ls[1:]],  # missing column
        lambda ls: [x for x in ls if not x.startswith("30,hysteresis")],  # none at ψ = 30°
        lambda ls: [ls[0], "0,direct,abc,0.0", *ls[2:]],  # text for a number
    ],
)
def test_bad_hysteresis_records_exit_2_and_write_nothing(tmp_path, edit):
    path, _ = _ring(tmp_path, cycles=3)
    _edit(path, edit)
    out, rep = tmp_path / "H.json", tmp_path / "H.html"
    result = runner.invoke(
        app, ["repeatability", "hysteresis", str(path), "-o", str(out), "--report", str(rep)]
    )
    assert result.exit_code == 2, result.output
    assert _single_error_line(result)
    assert not out.exists() and not rep.exists()
