"""LinuxCNC's joint screw compensation, emulated from its source: where the joint goes.

Semantics
---------
Repository LinuxCNC/linuxcnc, ``src/emc/motion/usrmotintf.cc``, ``usrmotLoadComp``, and
``src/emc/motion/control.c``, ``compute_screw_comp``; documentation
``docs/src/config/ini-config.adoc``, "[JOINT_<num>] Sections", ``COMP_FILE`` and
``COMP_FILE_TYPE``.

- **File.** One line per point, ``nominal forward reverse``; the loader reads each line
  with ``sscanf(buffer, "%lf %lf %lf", ...)`` and *stops at the first line that is not three
  numbers* — silently: a header line loads nothing.  Nominal positions in joint units (mm,
  degrees on a rotary joint), ascending; at most ``EMCMOT_COMP_SIZE`` = 256 entries.
- **What a value means, its sign.** ``COMP_FILE_TYPE = 0``: forward and reverse are the
  positions the joint *actually reaches* when commanded to the nominal one; the loader
  stores the trims ``nominal − actual``.  ``COMP_FILE_TYPE = 1``: the columns are the trims
  themselves.  ``compute_screw_comp`` puts the interpolated trim in
  ``joint->backlash_corr``, which is *added to the commanded joint position* sent to the
  motor: a positive trim moves the joint in the positive direction.  A trim of −E cancels
  an error E (actual − commanded); a type-0 file holds nominal + E.
- **Interpolation.** Linear between neighbouring entries (``fwd_trim + fwd_slope · dpos``).
- **Outside the table.** The loader brackets the table with entries at ±1e30 that carry
  the first and last trims with zero slope: the end values are held.
- **Direction.** The forward trim while the joint's commanded velocity is positive, the
  reverse trim while it is negative; at rest the last one stays.

This module is the check of :mod:`mtmetrology.export.linuxcnc`; it shares no code with it.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.export.control import ControlTable

__all__ = ["COMP_SIZE", "SEMANTICS", "load"]

#: ``EMCMOT_COMP_SIZE`` (src/emc/motion/motion.h).
COMP_SIZE = 256
_DEG = np.pi / 180.0

SEMANTICS = {
    "value": "correction",
    "sign_established": True,
    "source": (
        "LinuxCNC src/emc/motion/control.c compute_screw_comp (the trim is added to the "
        "commanded joint position) and src/emc/motion/usrmotintf.cc usrmotLoadComp "
        "(COMP_FILE_TYPE 0: trim = nominal - actual)"
    ),
}


def _rows(name: str, text: str) -> np.ndarray:
    """The entries the loader takes: lines of three numbers, up to the first other line.

    The real loader stops there without a word; a file of ours never has such a line, so
    here it is refused, naming the line, rather than half the table used.
    """
    rows = []
    for k, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        try:
            if len(fields) != 3:
                raise ValueError
            rows.append([float(v) for v in fields])
        except ValueError:
            raise InputError(
                f"{name}, line {k}: {line!r} is not three numbers; LinuxCNC's loader "
                f"(usrmotLoadComp) stops at it and would load only the {len(rows)} lines above"
            ) from None
    if len(rows) < 2:
        raise InputError(f"{name}: {len(rows)} entries; a compensation table needs at least 2")
    if len(rows) > COMP_SIZE:
        raise InputError(f"{name}: {len(rows)} entries; EMCMOT_COMP_SIZE is {COMP_SIZE}")
    a = np.array(rows)
    if np.any(np.diff(a[:, 0]) <= 0):
        raise InputError(f"{name}: nominal positions are not in ascending order")
    return a


def load(files: Mapping[str, str], joints: Mapping[str, str]) -> list[ControlTable]:
    """The joint displacements LinuxCNC applies, from the INI lines and the ``.comp`` files.

    Parameters
    ----------
    files : mapping of file name to text
        ``compensation.ini`` (the ``[JOINT_n]`` lines ``COMP_FILE`` and ``COMP_FILE_TYPE``)
        and the files it names.
    joints : mapping of joint number (str) to machine axis
        Which machine axis each joint drives, e.g. ``{"0": "X", "1": "Y"}``; a rotary
        axis's joint is in degrees.

    Returns
    -------
    list of ControlTable
        One per joint: positions and the displacement added to the joint (internal units),
        forward and reverse, linear with the end values held.

    Raises
    ------
    InputError
        A line the loader would stop at, a file not given, an unknown joint, a type not 0/1.
    """
    joint, settings = None, {}
    for k, line in enumerate(files.get("compensation.ini", "").splitlines(), start=1):
        line = line.split(";", 1)[0].split("#", 1)[0].strip()
        if not line:
            continue
        if line.startswith("[JOINT_") and line.endswith("]"):
            joint = line[len("[JOINT_") : -1]
            settings[joint] = {}
        elif "=" in line and joint is not None:
            key, value = (s.strip() for s in line.split("=", 1))
            settings[joint][key] = value
        else:
            raise InputError(f"compensation.ini, line {k}: cannot read {line!r}")
    out = []
    for j, entry in settings.items():
        if j not in joints:
            raise InputError(f"compensation.ini: [JOINT_{j}] is not a joint of the machine")
        name = entry.get("COMP_FILE")
        if name is None or name not in files:
            raise InputError(f"compensation.ini, [JOINT_{j}]: COMP_FILE {name!r} not given")
        file_type = entry.get("COMP_FILE_TYPE", "0")
        if file_type not in ("0", "1"):
            raise InputError(f"compensation.ini, [JOINT_{j}]: COMP_FILE_TYPE {file_type!r}")
        a = _rows(name, files[name])
        axis = joints[j]
        scale = 1.0 if axis in "XYZ" else _DEG
        nominal, forward, reverse = a[:, 0], a[:, 1], a[:, 2]
        if file_type == "0":  # actual positions reached: trim = nominal − actual
            forward, reverse = nominal - forward, nominal - reverse
        out.append(
            ControlTable(
                f"E_{axis}{axis}", nominal * scale, forward * scale, reverse * scale, "linear"
            )
        )
    return out
