"""The Sinumerik emulation against K3 (6FC5397-1BP40-3BA1, 03/2013), §4.4.

K3 §4.4.2.1, p. 238: "A positive compensation value causes the corresponding machine axis
to move in the negative direction."  The example of §4.4.2.3 (p. 242) gives the first three
values (+3, +10, +12 µm), the last (0) and the grid (−200 … 600 mm, step 1 mm) of axis X1.
"""

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.export.emulation import sinumerik


def _k3_example() -> str:
    """The p. 242 example: the values the manual prints; the points it elides ("...") zero."""
    printed = {0: 0.003, 1: 0.01, 2: 0.012, 800: -0.0}
    lines = ["%_N_AX_EEC_INI", "CHANDATA(1)"]
    lines += [f"$AA_ENC_COMP[0,{k},X1]={printed.get(k, 0.0)}" for k in range(801)]
    lines += [
        "$AA_ENC_COMP_STEP[0,X1]=1.0 ; Distance between interpolation points 1.0 mm",
        "$AA_ENC_COMP_MIN[0,X1]=-200.0 ; Compensation starts at -200.0 mm",
        "$AA_ENC_COMP_MAX[0,X1]=600.0 ; Compensation ends at +600.0 mm",
        "$AA_ENC_COMP_IS_MODULO[0,X1]=0 ; Compensation without modulo function",
        "M17",
    ]
    return "\n".join(lines) + "\n"


def test_k3_example_a_positive_value_moves_the_axis_negatively():
    """+3 µm at −200 mm moves X by −3 µm; halfway to point 1 (+10 µm) by −6.5 µm; the first
    value stays active below −200 mm and the last above 600 mm (p. 240)."""
    (t,) = sinumerik.load({"ENC_COMP.INI": _k3_example()}, {"X1": "X"})
    assert (t.function, t.positions.size) == ("E_XX", 801)
    got = t.correction(np.array([-200.0, -199.5, -250.0, 650.0, -198.0]))
    np.testing.assert_allclose(got, [-0.003, -0.0065, -0.003, 0.0, -0.012], atol=1e-15)


def test_cec_table_direction_and_axes():
    """$AN_CEC with basic axis (AX2) = Y and compensation axis (AX1) = X, positive direction
    only (DIRECTION 1): E_XY with a forward displacement −value and none in reverse."""
    text = "\n".join(
        [
            "%_N_NC_CEC_INI",
            "CHANDATA(1)",
            "$AN_CEC[0,0]=0",
            "$AN_CEC[0,1]=0.01",
            "$AN_CEC[0,2]=0.012",
            "$AN_CEC_INPUT_AXIS[0]=(AX2)",
            "$AN_CEC_OUTPUT_AXIS[0]=(AX1)",
            "$AN_CEC_STEP[0]=10",
            "$AN_CEC_MIN[0]=0",
            "$AN_CEC_MAX[0]=20",
            "$AN_CEC_DIRECTION[0]=1",
            "M17",
        ]
    )
    (t,) = sinumerik.load({"CEC.INI": text}, {"AX1": "X", "AX2": "Y"})
    assert (t.function, t.axis, t.output) == ("E_XY", "Y", "X")
    np.testing.assert_allclose(t.forward, [0.0, -0.01, -0.012])
    np.testing.assert_allclose(t.reverse, 0.0)


def test_an_axis_outside_the_map_and_a_grid_that_does_not_close_are_refused():
    text = _k3_example()
    with pytest.raises(InputError) as info:
        sinumerik.load({"ENC_COMP.INI": text}, {"X": "X"})
    assert str(info.value).startswith("ENC_COMP.INI, line 3: axis 'X1' is not a machine axis")
    bad = text.replace("$AA_ENC_COMP_MAX[0,X1]=600.0", "$AA_ENC_COMP_MAX[0,X1]=601.0")
    with pytest.raises(InputError) as info:
        sinumerik.load({"ENC_COMP.INI": bad}, {"X1": "X"})
    assert str(info.value) == ("ENC_COMP.INI, axis X: _MAX 601 is not _MIN + (points - 1) * _STEP")
