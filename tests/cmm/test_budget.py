"""The 15-item ball-plate budget (Salacheep 2016, §3.8) on the project's GUF."""

from __future__ import annotations

import numpy as np
import pytest

from mtmetrology.cmm.budget import BudgetSpec, ballplate_budget, cosine_error
from mtmetrology.units import to_internal

SPEC = dict(
    kind="ballplate-budget",
    length_mm=532.0,
    observed=dict(value_mm=532.01797, s_um=2.0, n=6),
    verification_um=1.0,
    indication_resolution_um=0.1,
    probe_reproducibility_um=0.5,
    air=dict(temperature_C=20.6, pressure_Pa=101325.0, humidity_percent=51.0),
    hygrometer_U_percent=1.1,
    humidity_resolution_percent=1.0,
    barometer_U_Pa=20.0,
    pressure_resolution_Pa=1.0,
    air_thermometer_U_K=0.02,
    air_thermometer_resolution_K=0.01,
    misalignment_um=50.0,
    part_temperature_C=20.6,
    part_thermometer_U_K=0.02,
    temperature_spread_K=0.5,
    cte_per_K=11.5e-6,
    cte_halfwidth_per_K=1.0e-6,
)


def test_items_and_combination():
    """Each item's standard uncertainty is the source's formula; u_c is their RSS."""
    res = ballplate_budget(BudgetSpec.model_validate(SPEC))
    rows = {r.input: r for r in res.budget(0)}
    um = to_internal(1.0, "µm")
    assert len(rows) == 14  # items 1–4 and 6–15; item 5 (δl_n) is the Edlén function of 6–11
    assert rows["l_obs"].u == pytest.approx(2.0 * um / np.sqrt(6))
    assert rows["dl_vm"].u == pytest.approx(1.0 * um / np.sqrt(3))
    assert rows["dl_is"].u == pytest.approx(0.1 * um / (2 * np.sqrt(3)))
    assert rows["dl_Ax"].u == pytest.approx(cosine_error(532.0, 0.05) / np.sqrt(3))
    assert rows["dt_d"].contribution == pytest.approx(532.0 * 11.5e-6 * 0.5 / np.sqrt(3), rel=1e-6)
    assert rows["d_alpha"].contribution == pytest.approx(532.0 * 0.6 * 1e-6 / np.sqrt(3), rel=1e-6)
    # refractive index: ∂l/∂p = −l0 ∂n/∂p ≈ −l0·2.7e-4/p (dry-air term dominates)
    assert rows["p_cal"].sensitivity == pytest.approx(-532.0 * 2.7e-4 / 101325.0, rel=0.02)
    rss = np.sqrt(sum(r.contribution**2 for r in rows.values()))
    assert res.standard_uncertainty[0] == pytest.approx(rss, rel=1e-9)
    # estimate: observed length corrected to 20 °C
    assert res.estimate[0] == pytest.approx(532.01797 * 1 - 532.0 * 11.5e-6 * 0.6, abs=1e-9)
    assert res.to_dict()["outputs"][0]["unit"] == "mm"
