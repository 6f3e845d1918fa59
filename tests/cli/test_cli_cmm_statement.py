"""``mtm cmm budget`` with a specification section: the statement at 532 mm."""

from __future__ import annotations

import json

import yaml
from typer.testing import CliRunner

from mtmetrology.cli import app

runner = CliRunner()

BUDGET = {
    "kind": "ballplate-budget", "length_mm": 532.0,
    "observed": {"value_mm": 532.01797, "s_um": 2.0, "n": 6}, "verification_um": 1.0,
    "indication_resolution_um": 0.1, "probe_reproducibility_um": 0.5,
    "air": {"temperature_C": 20.6, "pressure_Pa": 101325.0, "humidity_percent": 51.0},
    "hygrometer_U_percent": 1.1, "humidity_resolution_percent": 1.0, "barometer_U_Pa": 20.0,
    "pressure_resolution_Pa": 1.0, "air_thermometer_U_K": 0.02,
    "air_thermometer_resolution_K": 0.01, "misalignment_um": 50.0, "part_temperature_C": 20.6,
    "part_thermometer_U_K": 0.02, "temperature_spread_K": 0.5, "cte_per_K": 11.5e-6,
    "cte_halfwidth_per_K": 1.0e-6,
    "specification": {
        "cmm_U": {"a_um": 0.52, "b_um_per_mm": 1.4e-3},
        "plate_U": {"a_um": 0.26, "b_um_per_mm": 1.9e-3},
        "mpe_a_um": 0.6, "mpe_length_divisor": 600, "sphere_form_um": 0.2,
        "sphere_form_u_um": 0.05,
    },
}  # fmt: skip


def test_statement_in_the_budget_result(tmp_path):
    path, out = tmp_path / "budget.yaml", tmp_path / "budget.json"
    path.write_text(yaml.safe_dump(BUDGET), encoding="utf-8")
    res = runner.invoke(app, ["cmm", "budget", str(path), "-o", str(out)])
    assert res.exit_code == 0, res.output
    st = json.loads(out.read_text())["statement"]
    assert [round(st[k], 3) for k in ("U_cmm_um", "U_plate_um", "mpe_um")] == [
        0.908, 1.044, 1.487,
    ]  # fmt: skip
    assert st["k"] == 2.0 and st["U_E_um"] == 2 * st["u_E_um"]


def test_unknown_specification_key_exits_2_naming_it(tmp_path):
    bad = {**BUDGET, "specification": {**BUDGET["specification"], "mpe_b": 1.0}}
    path, out = tmp_path / "bad.yaml", tmp_path / "bad.json"
    path.write_text(yaml.safe_dump(bad), encoding="utf-8")
    res = runner.invoke(app, ["cmm", "budget", str(path), "-o", str(out)])
    assert res.exit_code == 2
    errors = [ln for ln in res.output.splitlines() if ln.startswith("error:")]
    assert len(errors) == 1 and "mpe_b" in errors[0]
    assert not out.exists()
