"""``mtm budget iso15530-3``: the refusals of issue 30 (exit 2, one line naming the option,
nothing written), --allow-few-repeats, --part with its decision, u_w from its inputs."""

from __future__ import annotations

import json
import math

import pytest
from typer.testing import CliRunner

from mtmetrology.cli import build_app

APP = build_app("budget")


def _write(path, values, series=None):
    rows = [f"{v:.12f}" + ("" if series is None else f",{series[i]}") for i, v in enumerate(values)]
    path.write_text(("value\n" if series is None else "value,series\n") + "\n".join(rows) + "\n")
    return path


def _runs(tmp_path, n=20, scale=1.0):
    """n repeats about 50.002 mm, sample s = 1 µm exactly for even n (±a alternating)."""
    a = 0.001 * math.sqrt((n - 1) / n)
    return _write(tmp_path / "runs.csv", [scale * (50.002 + a * (-1) ** i) for i in range(n)])


def _invoke(runs, *extra, out=None):
    args = ["budget", "iso15530-3", str(runs), "--calibrated", "50", "--u-cal", "0.5"]
    args += [str(a) for a in extra]
    if out is not None:
        args += ["-o", str(out)]
    return CliRunner().invoke(APP, args)


def _refused(result, out, *names):
    lines = result.stderr.splitlines()
    assert (result.exit_code, len(lines), result.stdout) == (2, 1, ""), result.output
    assert lines[0].startswith("error: ")
    for name in names:
        assert name in lines[0], (name, lines[0])
    assert not out.exists()


@pytest.mark.parametrize("policy", ["2004", "2011"])
def test_few_repeats_under_an_iso_policy_are_refused_naming_the_option(tmp_path, policy):
    out = tmp_path / "b.json"
    result = _invoke(_runs(tmp_path, n=5), "--policy", policy, out=out)
    _refused(result, out, "--allow-few-repeats", "5 repeats")


def test_a_series_of_too_few_cycles_is_refused_naming_it(tmp_path):
    runs = _write(tmp_path / "runs.csv", [50.002] * 11 + [50.003] * 9, ["A"] * 11 + ["B"] * 9)
    out = tmp_path / "b.json"
    _refused(_invoke(runs, "--policy", "2011", out=out), out, "series 'B' has 9 cycles")


def test_allow_few_repeats_warns_and_records_the_deviation(tmp_path):
    out = tmp_path / "b.json"
    result = _invoke(_runs(tmp_path, n=6), "--policy", "2004", "--allow-few-repeats", out=out)
    assert result.exit_code == 0, result.output
    assert result.stderr.splitlines() == [
        "warning: deviation from ISO 15530-3 (recorded): 6 repeats, ISO 15530-3 requires at "
        "least 20"
    ]
    assert json.loads(out.read_text())["deviations"] == [
        "6 repeats, ISO 15530-3 requires at least 20"
    ]


def test_runs_in_micrometres_against_millimetres_are_refused_naming_both(tmp_path):
    out = tmp_path / "b.json"
    _refused(_invoke(_runs(tmp_path, scale=1e3), out=out), out, "runs", "--calibrated")


def test_part_readings_in_another_unit_are_refused_naming_both(tmp_path):
    part = _write(tmp_path / "part.csv", [50.004e3])
    out = tmp_path / "b.json"
    _refused(_invoke(_runs(tmp_path), "--part", part, out=out), out, "--part", "--calibrated")


@pytest.mark.parametrize(
    ("extra", "option"),
    [
        (["--u-w", "1", "--form", "2"], "--u-w"),
        (["--temperature", "300", "--alpha-half-width", "1"], "--temperature"),
        (["--alpha-half-width", "1"], "--temperature"),
        (["--u-temperature", "0.2"], "--alpha"),
        (["--form", "-2"], "--form"),
        (["--length", "-5", "--form", "2"], "--length"),
        (["--alpha", "nan"], "--alpha"),
    ],
)
def test_bad_u_w_inputs_are_refused_naming_the_option(tmp_path, extra, option):
    out = tmp_path / "b.json"
    result = _invoke(_runs(tmp_path), *extra, out=out)
    _refused(result, out, option)


def test_a_production_part_outside_the_tolerance_is_non_conforming(tmp_path):
    """b = +2 µm, u_p = 1 µm, u_cal = 0.5 µm; policy 2011: the part's result is y − b,
    U = 2·√(1² + 0.5²) = 2.24 µm; a part at 50.015 mm → 50.013 ± 0.0022 > 50.010."""
    runs = _runs(tmp_path)
    tol = ["--tolerance", "50,-0.010,0.010", "--policy", "2011"]
    out = tmp_path / "b.json"
    bad = _write(tmp_path / "bad.csv", [50.0145, 50.0155])
    result = _invoke(runs, "--part", bad, *tol, out=out)
    assert result.exit_code == 0, result.output
    part = json.loads(out.read_text())["part"]
    assert part["name"] == "bad.csv" and part["bias_corrected"] is True
    assert part["result"] == pytest.approx(50.013, abs=1e-9)
    assert part["U"] == pytest.approx(2 * math.sqrt(1e-6 + 0.25e-6), rel=1e-6)
    assert part["decision"]["decision"] == "non-conformance"
    good = _write(tmp_path / "good.csv", [50.004])
    out2 = tmp_path / "b2.json"
    assert _invoke(runs, "--part", good, *tol, out=out2).exit_code == 0
    assert json.loads(out2.read_text())["part"]["decision"]["decision"] == "conformance"


def test_u_w_from_inputs_is_the_closed_form(tmp_path):
    """α 11.5 µm/(m·K), a_α 1 µm/(m·K), 23 °C ± 0.5 K, L = 50 mm (|x_cal|), F = 2 µm."""
    out = tmp_path / "b.json"
    args = ["--alpha", "11.5", "--alpha-half-width", "1", "--temperature", "23"]
    args += ["--u-temperature", "0.5", "--form", "2", "--policy", "2011"]
    result = _invoke(_runs(tmp_path), *args, out=out)
    assert result.exit_code == 0, result.output
    doc = json.loads(out.read_text())
    u_a = 1e-6 / math.sqrt(3.0)
    terms = [50 * 3 * u_a, 50 * 11.5e-6 * 0.5, 50 * u_a * 0.5, 0.002 / math.sqrt(12.0)]
    u_w = math.sqrt(sum(t * t for t in terms))
    assert doc["contributions"]["u_w"] == pytest.approx(u_w, rel=1e-12)
    assert doc["workpiece"]["length"] == 50.0
    assert doc["U"] == pytest.approx(2 * math.sqrt(1e-6 + 0.25e-6 + u_w**2), rel=1e-6)
