"""Issue 31, one way to state a result: every command that writes a report states k beside
each U (console, JSON, report), and prints no more digits than u allows (JCGM 100:2008,
7.2.6), no ``-0`` and no ``±`` without naming u or U.

The commands are those of ``command_reports`` (one run per session, shared with
``test_report_cli.py``); the demo's commands and documents are checked in
``test_report_demo.py`` and every command's JSON in ``tests/cli/test_cli_library_parity.py``.
"""

from __future__ import annotations

import html
import json
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.formatting import decimals_for, format_result, overstated_digits
from mtmetrology.uncertainty.coverage import unstated_coverage

runner = CliRunner()


def _text(page: Path) -> str:
    """What a reader sees of a report: no tags, styles, scripts or figures."""
    body = re.sub(r"(?s)<(style|script|svg)\b.*?</\1>", " ", page.read_text(encoding="utf-8"))
    return html.unescape(re.sub(r"<[^>]+>", " ", body))


def test_every_report_command_follows_the_policy(command_reports):
    """Console (stdout and stderr), the report's text and each JSON the command wrote."""
    broken = {}
    for name, (result, page) in command_reports.items():
        assert result.exit_code == 0, f"{name}: {result.output}"
        found = overstated_digits(f"{result.stdout}\n{result.stderr}")
        found += overstated_digits(_text(page))
        for written in page.parent.glob("*.json"):
            found += unstated_coverage(json.loads(written.read_text(encoding="utf-8")))
        if found:
            broken[name] = found
    assert broken == {}


def test_ballplate_budget_states_u_and_u_with_k(command_reports):
    """``l_x = 532.014299 mm, u = 2.06 µm`` became the value to the decimal of u's second
    digit, u and U named, k beside U; the JSON's U is k u at p = 2 Φ(2) − 1 (k = 2)."""
    result, page = command_reports["ballplate-budget"]
    doc = json.loads(page.with_name("budget.json").read_text(encoding="utf-8"))
    o = doc["outputs"][0]
    assert o["k"] == pytest.approx(2.0, abs=1e-9) and o["U"] == pytest.approx(o["k"] * o["u"])
    line = next(x for x in result.stderr.splitlines() if x.startswith("l_x = "))
    u_um = o["u"] * 1e3  # mm -> µm, the test's own conversion
    assert line.startswith(
        format_result(o["value"], u_um, "mm", name="l_x", u_unit="µm", k=o["k"], p=o["p"])
    )
    value = line.split()[2]
    assert len(value.split(".")[1]) == decimals_for(o["u"])


def test_iso15530_and_coverage_options(tmp_path):
    """``108.001825 mm ± 5.8 µm`` became ``result = … mm, u = … µm, U = … µm (k = 2)``;
    --k 3 gives U = 3 u in the JSON and on the console; --k with --p is refused."""
    runs = tmp_path / "runs.csv"
    values = [50.0012, 50.0008, 50.0015, 50.0011, 50.0009] * 4
    runs.write_text("value\n" + "\n".join(f"{v:.4f}" for v in values) + "\n")
    common = ["budget", "iso15530-3", str(runs), "--calibrated", "50", "--u-cal", "0.5"]
    for k in (None, 3.0):
        out = tmp_path / f"k{k}.json"
        args = [*common, "-o", str(out)] + ([] if k is None else ["--k", str(k)])
        result = runner.invoke(app, args)
        assert result.exit_code == 0, result.output
        doc = json.loads(out.read_text())
        assert doc["k"] == (2.0 if k is None else k)
        assert doc["um"]["U"] == pytest.approx(doc["k"] * doc["um"]["u"])
        assert overstated_digits(result.stdout) == []
        line = next(x for x in result.stdout.splitlines() if x.strip().startswith("result = "))
        assert line.rstrip().endswith(f"(k = {doc['k']:g})")
    refused = runner.invoke(app, [*common, "--k", "2", "--p", "0.95"])
    assert refused.exit_code == 2 and "--k and --p" in refused.stderr


def test_history_show_names_u_and_drift_states_its_interval(tmp_path, monkeypatch):
    """``history show`` wrote ``1.9000 ± 0.3 µm`` and ``drift`` ``8.07 ± 1.2 µm/year``: now
    ``E_X0C = 1.90 µm, u = 0.30 µm`` and ``slope = … µm/year, u = … µm/year``."""
    import numpy as np

    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.parameter_set import ParameterSet

    monkeypatch.setenv("MTMETROLOGY_DB", str(tmp_path / "h.sqlite"))
    machine = Machine.load("five-axis-wcbxfzyst")
    j = machine.parameter_names.index("E_X0C")
    scales = machine.parameter_scales  # µm -> internal units, as the history tests
    for i, x in enumerate((1.9, 2.6, 4.1, 4.9, 6.2, 7.0)):
        row = np.zeros(machine.n_params)
        row[j] = x
        path = tmp_path / f"r{i}.json"
        ParameterSet(
            machine.parameter_names,
            row * scales,
            machine.parameter_units,
            np.diag((0.3 * scales) ** 2),
            machine=machine.name,
            model="13",
        ).save(path)
        added = runner.invoke(app, ["history", "add", str(path), "--date", f"2026-0{i + 1}-01"])
        assert added.exit_code == 0, added.output
    shown = runner.invoke(app, ["history", "show", "1"])
    assert shown.exit_code == 0, shown.output
    assert "  E_X0C = 1.90 µm, u = 0.30 µm" in shown.stdout.splitlines()
    drift = runner.invoke(app, ["history", "drift", "E_X0C", "--k", "2"])
    assert drift.exit_code == 0, drift.output
    for result in (shown, drift):
        assert overstated_digits(result.stdout) == []
    assert re.search(r"slope = \S+ µm/year, u = \S+ µm/year", drift.stdout)
