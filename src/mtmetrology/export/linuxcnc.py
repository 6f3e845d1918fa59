"""LinuxCNC joint compensation files (``[JOINT_n] COMP_FILE``, ``COMP_FILE_TYPE``).

Format (LinuxCNC documentation, *INI Configuration*, ``docs/src/config/ini-config.adoc``,
section "[JOINT_<num>] Sections", items ``COMP_FILE`` and ``COMP_FILE_TYPE``; loader
``src/emc/motion/usrmotintf.cc``, ``usrmotLoadComp``):

- one file per joint, one line per point: ``nominal forward reverse``, positions in
  ascending order, in machine units (mm; degrees for a rotary joint);
- at most 256 lines per joint (``EMCMOT_COMP_SIZE``, ``src/emc/motion/motion.h``);
- ``COMP_FILE_TYPE = 0``: forward and reverse are the *actual* positions the joint reaches
  when commanded to the nominal one; the loader stores ``nominal − actual`` as the trim;
- ``COMP_FILE_TYPE = 1``: forward and reverse are the trims themselves, added to the
  commanded joint position, i.e. *corrections* (−E);
- values are linearly interpolated between points; ``BACKLASH`` is ignored when a
  compensation file is set, so the reversal is carried by the two columns.

A joint table compensates the joint's own position: the functions carried are the
positioning errors ``E_XX``, ``E_YY``, ``E_ZZ``, ``E_AA``, ``E_BB``, ``E_CC``.

Semantics
---------
Repository LinuxCNC/linuxcnc: ``src/emc/motion/control.c``, ``compute_screw_comp`` and the
motor command ``motor_pos_cmd = pos_cmd + backlash_filt + motor_offset`` (the trim is
*added to the commanded joint position*); ``src/emc/motion/usrmotintf.cc``,
``usrmotLoadComp`` (type 0: ``fwd = nom - fwd``, the trim is nominal − actual).

- **Value and sign**: ``COMP_FILE_TYPE = 1`` (written by default) holds the trims, the
  corrections −E; type 0 the actual positions nominal + E.
- **Unit**: machine units, mm (degrees on a rotary joint); positions from the joint's home.
- **Interpolation**: linear between entries; **outside** the table the end trims are held.
- **Direction**: the forward column while the commanded velocity is positive, the reverse
  column while it is negative.
- **No header line**: the loader stops silently at the first line that is not three
  numbers, so the ``.comp`` files hold data lines only.
- The emulation the export's residual comes from is
  :mod:`mtmetrology.export.emulation.linuxcnc`.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.export._common import check_points, corrections, select
from mtmetrology.export.control import ControlTable
from mtmetrology.export.model import CompensationModel, ErrorTable
from mtmetrology.kinematics.topology import LINEAR_AXES

__all__ = ["MAX_POINTS", "build", "render"]

NAME = "linuxcnc"
MAX_POINTS = 256
_DEG = np.pi / 180.0
_JOINT_AXES = "XYZABC"


def _carries(table: ErrorTable) -> str | None:
    if table.component != table.axis:
        return "a joint table compensates its own joint's position only"
    return None


def build(
    model: CompensationModel, functions: Sequence[str] | None = None, *, file_type: int = 1
) -> list[ControlTable]:
    """The joint tables LinuxCNC will apply (corrections, linear interpolation).

    Raises
    ------
    InputError
        More than 256 points, or a function a joint table cannot carry.
    """
    if file_type not in (0, 1):
        raise InputError(f"COMP_FILE_TYPE: {file_type} is not 0 or 1")
    out = []
    for t in select(model, _carries, functions, NAME):
        check_points(NAME, t.function, t.positions.size, MAX_POINTS, "lines per joint file")
        fwd, rev = corrections(model, t)
        out.append(ControlTable(t.function, t.positions, fwd, rev, "linear"))
    return out


def _scale(axis: str) -> float:
    return 1.0 if axis in LINEAR_AXES else _DEG


def render(tables: list[ControlTable], model: CompensationModel, *, file_type: int = 1) -> dict:
    """File name -> text: one ``.comp`` file per joint and the INI lines that load them."""
    files = {}
    ini = ["; mtmetrology export: joint compensation files (LinuxCNC INI, [JOINT_n] sections)"]
    joints = [a for a in model.machine.axis_names if a in _JOINT_AXES]
    for t in tables:
        s = _scale(t.axis)
        nominal = t.positions / s
        if file_type == 1:
            cols = (t.forward / s, t.reverse / s)
        else:  # actual positions: nominal − trim
            cols = (nominal - t.forward / s, nominal - t.reverse / s)
        name = f"{t.axis.lower()}.comp"
        files[name] = "".join(
            f"{a:.6f} {b:.6f} {c:.6f}\n" for a, b, c in zip(nominal, *cols, strict=True)
        )
        ini += [
            f"[JOINT_{joints.index(t.axis)}]",
            f"COMP_FILE = {name}",
            f"COMP_FILE_TYPE = {file_type}",
        ]
    files["compensation.ini"] = "\n".join(ini) + "\n"
    return files
