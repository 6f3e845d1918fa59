"""The scripts of ``examples/`` that ``mtm demo`` runs: each runs on its own.

Each script is run as a user runs it, ``python examples/NAME.py OUT``, in a subprocess
with a temporary output folder; the files it writes are checked on their structured
fields against published figures (GUM H.1), exact properties (the minimum-zone width is
the range of its residuals) and what the simulation knows (the true sphere, full rank).
``samba_calibration.py`` is run through ``task_uncertainty.py``, which calibrates first
when it finds no calibration: one run checks both. ``mtm demo`` runs them all in one
folder (tests/report/test_report_demo.py).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from mtmetrology.report.demo import EXAMPLES, MARKER

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES_DIR = ROOT / "examples"


def _run(name: str, out: Path) -> str:
    env = {
        **os.environ,
        "PYTHONPATH": str(ROOT / "src"),
        "OMP_NUM_THREADS": "1",
        "OPENBLAS_NUM_THREADS": "1",
        "COLUMNS": "400",
    }
    result = subprocess.run(
        [sys.executable, str(EXAMPLES_DIR / name), str(out)],
        capture_output=True,
        text=True,
        env=env,
        cwd=out.parent,
        timeout=600,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    last = [line for line in result.stdout.splitlines() if line.strip()][-1]
    assert last == f"report: {out / 'report.html'}"
    assert (out / MARKER).is_file() and (out / "report.html").is_file()
    return result.stdout


def _json(out: Path, *parts: str) -> dict:
    return json.loads(out.joinpath(*parts).read_text(encoding="utf-8"))


def check_five_axis_machine(out: Path, stdout: str) -> None:
    ranks = re.search(r"SAMBA plan: rank (\d+)/(\d+); with E_Y0C rank (\d+)/(\d+) \((.*)\)", stdout)
    rank, unknowns, rank_y0c, unknowns_y0c = map(int, ranks.groups()[:4])
    assert rank == unknowns and unknowns_y0c == unknowns + 1 and rank_y0c == rank
    assert set(re.split(r"[ ~;]+", ranks.group(5))) == {"E_Y0S", "E_Y0C"}
    assert (out / "samba" / "plan.csv").is_file() and (out / "samba" / "samba.yaml").is_file()


def check_samba_planning(out: Path, stdout: str) -> None:
    plan = _json(out, "planning", "plan.json")
    assert plan["kind"] == "samba-design" and len(plan["balls"]) == 2
    assert plan["rank"] == plan["n_unknowns"]


def check_task_uncertainty(out: Path, stdout: str) -> None:
    params = _json(out, "samba", "params.json")  # samba_calibration.py, run first
    assert params["kind"] == "samba-calibration" and len(params["parameters"]) == 13
    check = _json(out, "gauge", "length-check.json")
    assert check["compensated"]["rms"] < check["nominal"]["rms"] / 5
    task = _json(out, "task", "gauge-length.json")
    decision = task["decision"]  # the true length is mid-tolerance: conformance
    low, high = decision["acceptance_zone"]
    assert low <= decision["value"] <= high and decision["decision"] == "conformance"
    coverage = _json(out, "task", "coverage.json")
    # 95 % intervals: at most `covered` of n is not improbable (P >= 1 % under p = 0.95)
    assert coverage["binomial_p_at_most_covered"] >= 0.01


def check_gum_h1_uncertainty(out: Path, stdout: str) -> None:
    result = _json(out, "uncertainty", "gum-h1-result.json")
    (guf,) = result["guf"]["outputs"]
    (mcm,) = result["mcm"]["outputs"]
    assert round(guf["u"]) == 32 and round(guf["U"]) == 93  # GUM H.1.6: 32 nm, U_99 93 nm
    assert round(mcm["u"]) == 34  # GUM H.1.7, second order: 34 nm
    assert result["validation"]["passed"] is False


def check_sphere_fitting(out: Path, stdout: str) -> None:
    fit = _json(out, "fitting", "sphere-result.json")
    p = {q["name"]: q["value"] for q in fit["parameters"]}
    # the simulated sphere: centre (10, -20, 5) mm, radius 12.7 mm, 2 µm radial noise
    assert abs(p["r"] - 12.7) < 0.002
    assert max(abs(p["x0"] - 10), abs(p["y0"] + 20), abs(p["z0"] - 5)) < 0.005
    res = fit["residuals"]
    assert res["unit"] == fit["form_error"]["unit"] == "µm"
    # the minimum-zone width is the range of the radial residuals about its centre
    assert fit["form_error"]["value"] == pytest.approx(res["max"] - res["min"], abs=1e-6)


def check_cmm_ballplate(out: Path, stdout: str) -> None:
    cal = _json(out, "cmm", "calibration.json")
    assert cal["fit"]["rank"] == cal["fit"]["n_unknowns"]
    assert 0.3 < cal["fit"]["rms_residual_um"] < 0.7  # 0.5 µm reading noise
    assert (out / "cmm" / "gp.json").is_file()


CHECKS = {
    "five_axis_machine.py": check_five_axis_machine,
    "samba_planning.py": check_samba_planning,
    "task_uncertainty.py": check_task_uncertainty,
    "gum_h1_uncertainty.py": check_gum_h1_uncertainty,
    "sphere_fitting.py": check_sphere_fitting,
    "cmm_ballplate.py": check_cmm_ballplate,
}


def test_the_demo_runs_every_example_script_and_each_is_checked_here():
    assert (set(EXAMPLES) - {"samba_calibration.py"}) == set(CHECKS)
    assert all((EXAMPLES_DIR / name).is_file() for name in EXAMPLES)


@pytest.mark.parametrize("name", sorted(CHECKS), ids=str)
def test_example_runs_on_its_own(name, tmp_path):
    out = tmp_path / "out"
    stdout = _run(name, out)
    CHECKS[name](out, stdout)
