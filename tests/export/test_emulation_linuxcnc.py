"""The LinuxCNC emulation against LinuxCNC's own documentation and source.

Golden cases: the example tables of ``docs/src/config/ini-config.adoc`` ("[JOINT_<num>]
Sections", ``COMP_FILE_TYPE``), read with the semantics of ``usrmotLoadComp`` (type 0:
trim = nominal − actual) and ``compute_screw_comp`` (the trim is added to the commanded
joint position, linear between entries, end values held, forward/reverse by the sense of
travel).
"""

import numpy as np
import pytest

from mtmetrology.errors import InputError
from mtmetrology.export.emulation import linuxcnc

# ini-config.adoc, COMP_FILE_TYPE = 0: nominal, actual moving up, actual moving down.
TYPE_0 = "-1.000 -1.005 -0.995\n0.000 0.002 -0.003\n1.000 1.003 0.998\n"
# ini-config.adoc, COMP_FILE_TYPE = 1: nominal, offset moving up, offset moving down.
TYPE_1 = "-1.000 0.005 -0.005\n0.000 0.002 -0.003\n1.000 0.003 -0.004\n"


def _load(text: str, file_type: int):
    ini = f"[JOINT_0]\nCOMP_FILE = x.comp\nCOMP_FILE_TYPE = {file_type}\n"
    (table,) = linuxcnc.load({"compensation.ini": ini, "x.comp": text}, {"0": "X"})
    return table


def test_type_0_documented_rows_give_the_trims_nominal_minus_actual():
    """Row ``1.000 1.003 0.998``: the joint overshoots by 3 µm moving up, so the trim is
    −0.003 up and +0.002 down; row ``-1.000 -1.005 -0.995``: +0.005 and −0.005."""
    t = _load(TYPE_0, 0)
    np.testing.assert_allclose(t.forward, [0.005, -0.002, -0.003], atol=1e-15)
    np.testing.assert_allclose(t.reverse, [-0.005, 0.003, 0.002], atol=1e-15)


def test_type_1_rows_are_the_trims_as_written():
    t = _load(TYPE_1, 1)
    np.testing.assert_allclose(t.forward, [0.005, 0.002, 0.003])
    np.testing.assert_allclose(t.reverse, [-0.005, -0.003, -0.004])


def test_interpolation_between_entries_and_end_values_held_by_sense_of_travel():
    """Type 0 at 0.5 moving up: (−0.002 − 0.003)/2 = −0.0025; at −2.0 moving up the first
    trim +0.005 is held; at 3.0 moving down the last, +0.002."""
    t = _load(TYPE_0, 0)
    q = np.array([0.5, -2.0, 3.0])
    got = t.correction(q, np.array([1, 1, -1]))
    np.testing.assert_allclose(got, [-0.0025, 0.005, 0.002], atol=1e-15)


def test_a_header_line_is_refused_because_the_loader_would_stop_at_it():
    """usrmotLoadComp breaks at the first line sscanf cannot read as three numbers: a header
    would load nothing, silently; the emulation names the line instead."""
    with pytest.raises(InputError) as info:
        _load("# nominal forward reverse\n" + TYPE_1, 1)
    assert str(info.value).startswith("x.comp, line 1: '# nominal forward reverse' is not three")
    assert "would load only the 0 lines above" in str(info.value)


def test_more_entries_than_emcmot_comp_size_are_refused():
    text = "".join(f"{k:.1f} 0 0\n" for k in range(257))
    with pytest.raises(InputError) as info:
        _load(text, 1)
    assert str(info.value) == "x.comp: 257 entries; EMCMOT_COMP_SIZE is 256"


def test_the_default_file_type_is_0_as_in_inijoint():
    """inijoint.cc reads COMP_FILE_TYPE with default 0: a file without the line holds
    actual positions."""
    ini = "[JOINT_0]\nCOMP_FILE = x.comp\n"
    (t,) = linuxcnc.load({"compensation.ini": ini, "x.comp": TYPE_0}, {"0": "X"})
    np.testing.assert_allclose(t.forward[-1], -0.003)
