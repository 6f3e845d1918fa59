"""The CMM's U and MPE at 532 mm and u(P), u(E) (Salacheep 2016, eqs 3.10–3.13, App. 1)."""

from __future__ import annotations

import numpy as np
import pytest
from test_budget import SPEC

from mtmetrology.cmm.budget import BudgetSpec, cmm_statement, cosine_error
from mtmetrology.cmm.statement import CMMStatement
from mtmetrology.errors import InputError

SOURCE_SPEC = dict(  # Appendix 1: PMM-C 700P and KOBA-check plate
    cmm_U=dict(a_um=0.52, b_um_per_mm=1.4e-3),
    plate_U=dict(a_um=0.26, b_um_per_mm=1.9e-3),
    mpe_a_um=0.6,
    mpe_length_divisor=600.0,
    sphere_form_um=0.2,
    sphere_form_u_um=0.05,
    fixturing_u_um=0.1,
)


@pytest.fixture(scope="module")
def statement() -> CMMStatement:
    return cmm_statement(BudgetSpec.model_validate({**SPEC, "specification": SOURCE_SPEC}))


def test_source_spot_values_at_532_mm(statement):
    """Digest 002 §3.1 (T14): U_CMM 0.908, U_plate 1.044, MPE 1.487 µm at 532 mm."""
    assert statement.length_mm == 532.0
    assert round(statement.U_cmm_um, 3) == 0.908
    assert round(statement.U_plate_um, 3) == 1.044
    assert round(statement.mpe_um, 3) == 1.487


def test_u_p_is_eq_3_10(statement):
    assert statement.u_P_um == pytest.approx(np.hypot(0.2 / 2, 0.05), rel=1e-12)
    assert statement.U_P_um == pytest.approx(2 * statement.u_P_um)


def test_u_e_is_eq_3_11_from_the_budget_inputs(statement):
    """The source labels eq. 3.11 "u(P)"; its five terms are the length test's, u(E)."""
    items = statement.E_items_um
    assert items["cal"] == pytest.approx(np.hypot(0.26, 1.9e-3 * 532) / 2, rel=1e-12)
    # |t − 20| u(α) l: 0.6 K · (1e-6/√3) /K · 532 mm
    assert items["alpha"] == pytest.approx(532.0 * 0.6 * 1e-6 / np.sqrt(3) * 1e3, rel=1e-12)
    u_t = np.hypot(0.02 / 2, 0.5 / np.sqrt(3))
    assert items["t"] == pytest.approx(532.0 * 11.5e-6 * u_t * 1e3, rel=1e-12)
    assert items["align"] == pytest.approx(cosine_error(532.0, 0.05) / np.sqrt(3) * 1e3)
    assert items["fixt"] == 0.1
    rss = np.sqrt(sum(v**2 for v in items.values()))
    assert statement.u_E_um == pytest.approx(rss, rel=1e-12)
    assert statement.U_E_um == pytest.approx(2 * rss)


def test_round_trip(statement):
    assert CMMStatement.from_dict(statement.to_dict()) == statement


def test_without_specification_is_refused():
    with pytest.raises(InputError, match="specification"):
        cmm_statement(BudgetSpec.model_validate(SPEC))
