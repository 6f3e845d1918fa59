"""Etalon exchange format: the documented example reads as the ISG kernel reads it, and
ISG_CSV and Etalon files of one model give the same tables."""

import numpy as np

from mtmetrology.export import etalon, isg
from mtmetrology.export.emulation import emulate
from mtmetrology.export.model import compensation_model
from mtmetrology.kinematics import Machine

# The programming examples of Beckhoff Information System TF5280, "Etalon Exchange Format"
# (position errors and a lookup table; three records of the table shown).
DOCUMENTED = """// Every parameter is specified in a block.
// The block begins with the name of the parameter in square brackets.
[C0B]
VALUE = 0.000022355737
[A0B]
VALUE = 0.000047622950
// Lookup tables are specified via a 2D array called "Gridpoints".
[EXY]
Gridpoints = {
          -280.0 -0.001358635132
          -270.0 -0.000240680764
          -260.0 0.000877273605
}  // end of EXY
"""


def test_the_documented_example_reads_as_errors_of_the_named_functions():
    """[C0B] is the location error E_C0B (rad), [EXY] the straightness E_XY over Y (mm);
    the control holds their negatives as corrections."""
    m = Machine.load("three-axis-xfyz")
    lis = "chain XYZ\nworkpiece_axes 1\nfile[0] volcomp.exc\nfile_format[0] ETALON_EXCHANGE\n"
    emulated = emulate("etalon", {"volcomp.lis": lis, "volcomp.exc": DOCUMENTED}, m)
    tables, consts = emulated.tables, emulated.constants
    assert consts == (("E_C0B", -0.000022355737), ("E_A0B", -0.000047622950))
    (table,) = tables
    assert (table.function, table.axis, table.output) == ("E_XY", "Y", "X")
    np.testing.assert_array_equal(table.positions, [-280.0, -270.0, -260.0])
    np.testing.assert_array_equal(table.forward, [0.001358635132, 0.000240680764, -0.000877273605])


def test_etalon_and_isg_csv_carry_the_same_model(make_set):
    m = Machine.load("three-axis-xfyz")
    values = {"E_XX1": 12.0, "E_YX2": 4.0, "E_BX1": 6.0, "E_C0Y": 15.0}
    cm = compensation_model(m, make_set(m, values), pitch=20)
    tables = isg.build(cm)
    files = etalon.render(tables, cm)
    assert "file_format[0] ETALON_EXCHANGE" in files["volcomp.lis"].splitlines()
    a = emulate("etalon", files, m)
    b = emulate("isg", isg.render(tables, cm), m)
    (a_tables, a_consts), (b_tables, b_consts) = (a.tables, a.constants), (b.tables, b.constants)
    assert [t.function for t in a_tables] == [t.function for t in b_tables]
    for a, b in zip(a_tables, b_tables, strict=True):
        np.testing.assert_allclose(a.forward, b.forward, atol=1e-12)
    np.testing.assert_allclose([v for _, v in a_consts], [v for _, v in b_consts], atol=1e-15)
