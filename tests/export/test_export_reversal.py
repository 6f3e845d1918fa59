"""Per-direction tables: a reversal term E_XXb exported for both directions of approach
(LinuxCNC forward/reverse columns; Fanuc's bidirectional parameters: test_fanuc.py) and
the residual checked for travel in either direction."""

import numpy as np
import pytest

from mtmetrology.export import linuxcnc
from mtmetrology.export.emulation import emulate
from mtmetrology.export.model import compensation_model
from mtmetrology.export.workflow import export_compensation


@pytest.mark.parametrize(
    ("fmt", "bound_um"),
    # LinuxCNC: linear interpolation of a linear error is exact (file rounding 5e-4 µm);
    # Fanuc: the table is zero at the reference X = 0, so the forward correction there,
    # 3 µm (stated in the notes), remains, plus one increment of the staircase
    # (100 µm/m × 20 mm = 2 µm) and half a unit.
    # ISG bilateral SSFK: values in 0.1 µm, each rounded to 0.05 µm.
    [("linuxcnc", 1e-3), ("fanuc", 3.0 + 2.5 + 1e-3), ("isg", 0.05 + 1e-3)],
)
def test_both_directions_of_approach_are_compensated(reversal_machine, make_set, fmt, bound_um):
    machine = reversal_machine
    """The check for travel in the negative direction uses the reverse table: the residual
    is the same in both directions at every check point (a forward table alone would leave
    the 2 · 3 µm reversal between them) and within the format's bound."""
    ps = make_set(machine, {"E_XX1": 100.0, "E_XXb": 3.0})
    res = export_compensation(machine, ps, fmt, pitch=20, functions=["E_XX"]).residual
    neg = res["negative"]
    before = np.asarray(neg["r_um"]) - np.asarray(res["r_um"])
    assert neg["uncompensated_max_um"] > 3.0
    np.testing.assert_allclose(before, 0.0, atol=0.1)
    assert res["max_um"] <= bound_um
    assert neg["max_um"] <= bound_um


def test_linuxcnc_reverse_column_carries_the_reversal(reversal_machine, make_set):
    machine = reversal_machine
    """The reverse column read back is the forward one plus 2 · E_XXb (corrections)."""
    ps = make_set(machine, {"E_XX1": 100.0, "E_XXb": 3.0})
    cm = compensation_model(machine, ps, pitch=20)
    files = linuxcnc.render(linuxcnc.build(cm, ["E_XX"]), cm)
    (back,) = emulate("linuxcnc", files, machine).tables
    np.testing.assert_allclose(back.reverse - back.forward, 6e-3, atol=1e-9)
