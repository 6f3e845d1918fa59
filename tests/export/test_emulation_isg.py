"""The ISG emulation against Beckhoff's TF5200/TF5280 documentation.

Golden case: the leadscrew-compensation example "Non-equidistant bilateral SSFK" (TF5200
*Axis compensation*): set point 19866.7 µm, measured 19856.5 µm (positive direction) and
19874.7 µm (negative direction); "computed pos compensation value Δs_i = s_ist,i − s_soll,i"
gives −102 and +80 (0.1 µm).  The documentation's list prints that set point as
``-198667``; the test keeps to the stated magnitudes and the formula.
"""

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.export import isg as isg_writer
from mtmetrology.export.emulation import isg
from mtmetrology.export.model import compensation_model


def _ssfk(pos: int, neg: int) -> str:
    lines = [
        "kopf.log_achs_name X",
        "kw.ssfk.interval 10000",
        "kw.ssfk.kw_startpos 188667",
        "kw.ssfk.kw_nr_max 3",
        "kw.ssfk.unit 1",
        "kw.ssfk.bilateral 1",
    ]
    lines += [f"kw.ssfk.table[{i}].pos {pos}" for i in range(3)]
    lines += [f"kw.ssfk.table[{i}].neg {neg}" for i in range(3)]
    return "\n".join(lines) + "\n"


def test_beckhoff_example_the_list_holds_the_error_and_the_setpoint_is_corrected_by_its_negative():
    set_point, measured_pos, measured_neg = 19866.7, 19856.5, 19874.7  # µm
    pos = round((measured_pos - set_point) * 10)  # Δs = s_ist − s_soll in 0.1 µm
    neg = round((measured_neg - set_point) * 10)
    assert (pos, neg) == (-102, 80)
    tables, constants, _ = isg.load({"ssfk_x.lis": _ssfk(pos, neg)}, "XYZ", 1)
    (t,) = tables
    assert constants == ()
    q = np.array([set_point * 1e-3])
    # commanded to the set point, the control moves the axis by −Δs: it lands on the target
    np.testing.assert_allclose(t.correction(q, np.array([1])), 10.2e-3, atol=1e-12)
    np.testing.assert_allclose(t.correction(q, np.array([-1])), -8.0e-3, atol=1e-12)


def test_our_writer_gives_the_documented_values_for_the_documented_errors(
    reversal_machine, make_set
):
    """E_XX = E_XX1 · x + E_XXb · sense with −10.2 µm (positive travel) and +8.0 µm
    (negative travel) at x = 20 mm: E_XXb = −9.1 µm, E_XX1 = −1.1 µm / 20 mm = −55 µm/m;
    the bilateral list writes −102 and +80 at that point, as Beckhoff's example."""
    ps = make_set(reversal_machine, {"E_XX1": -55.0, "E_XXb": -9.1})
    cm = compensation_model(reversal_machine, ps, pitch=20)
    text = isg_writer.render(isg_writer.build(cm, ["E_XX"]), cm)["ssfk_x.lis"]
    entries = dict(line.split() for line in text.splitlines() if not line.startswith("#"))
    assert (entries["kw.ssfk.table[1].pos"], entries["kw.ssfk.table[1].neg"]) == ("-102", "80")


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("chain WXFYZT", "chain 'WXFYZT': only the axis letters X, Y, Z, A, B, C"),
        ("negate 0", "negate '0': only the axis letters X, Y, Z, A, B, C"),
        ("negate XA", "negate 'XA': Cartesian axes only"),
        ("workpiece_axes 6", "workpiece_axes '6': 0 to 5"),
    ],
)
def test_lis_settings_outside_their_documented_range_are_refused(line, message):
    """P-VOLC-00007: chain of X, Y, Z, A, B, C; P-VOLC-00009: negate a set of Cartesian
    axes (``negate XY``); P-VOLC-00008: 0 ≤ workpiece_axes < 6."""
    with pytest.raises(InputError) as info:
        isg.load({"volcomp.lis": f"# list\n{line}\n"}, "XYZ", 1)
    assert str(info.value).startswith(f"volcomp.lis, line 2: {message}")


def test_negate_flips_and_set_to_zero_removes_the_named_components():
    lis = "chain XYZ\nworkpiece_axes 1\nnegate XY\nset_to_zero Z\n"
    _, _, factors = isg.load({"volcomp.lis": lis}, "XYZ", 1)
    np.testing.assert_array_equal(factors, [-1.0, -1.0, 0.0])


def test_a_chain_other_than_the_machine_s_is_refused():
    with pytest.raises(InputError) as info:
        isg.load({"volcomp.lis": "chain XYZ\nworkpiece_axes 0\n"}, "XYZ", 1)
    assert str(info.value) == (
        "volcomp.lis: chain XYZ with workpiece_axes 0 is not the machine's chain XYZ with "
        "1 workpiece-side axes"
    )


def test_the_writer_states_the_machine_chain_in_documented_form(make_set):
    """Five-axis WCBXFZYST: from the workpiece to the tool C, B, X, then Z, Y; three axes on
    the workpiece side; no negate line (default: nothing negated)."""
    from mtmetrology.kinematics import Machine

    m = Machine.load("five-axis-wcbxfzyst")
    cm = compensation_model(m, make_set(m, {"E_XX1": 10.0}), pitch=20)
    lis = isg_writer.render(isg_writer.build(cm, ["E_XX"]), cm)["volcomp.lis"].splitlines()
    assert "chain CBXZY" in lis and "workpiece_axes 3" in lis
    assert not any(line.startswith("negate") for line in lis)
