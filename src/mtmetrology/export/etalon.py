"""Etalon exchange format for the ISG kernel's Volumetric Compensation.

Format (Beckhoff Information System, TF5280 *Volumetric Compensation*, "Etalon Exchange
Format", infosys.beckhoff.com/content/1033/tf5280_volumetric_comp/296430091.html, and the
parameter P-VOLC-00013 ``file_format[j]`` = ``ETALON_EXCHANGE``, TF5200 *Volumetric
compensation parameters*, …/tf5200_volumetric_comp_params/106040587486243723.html):

- INI-like: ``//`` starts a comment; every parameter is a block opened by its name in
  square brackets;
- a position (location) error: ``[C0B]`` then ``VALUE = <value>``;
- a lookup table: ``[EXY]`` then ``Gridpoints = {``, one record ``argument value`` per line
  (the German page: "Argument Parameterwert"), and ``}``;
- the "Vendor" variant (the one the control reads).

The values are those of ``volcomp.csv`` (:mod:`mtmetrology.export.isg`): errors in mm and
rad, arguments in mm or degrees, ``negate 0`` in the ``.lis``; the tables, the location
errors, the per-direction SSFK lists and the control's interpolation are the ISG kernel's.

Semantics
---------
As :mod:`mtmetrology.export.isg`: the values are the ISO 230-1 errors the kernel corrects;
the emulation the residual comes from is :mod:`mtmetrology.export.emulation.isg`.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.export import isg
from mtmetrology.export.control import ControlTable
from mtmetrology.export.model import CompensationModel
from mtmetrology.kinematics.topology import LINEAR_AXES

__all__ = ["build", "render"]

NAME = "etalon"
FILE = "volcomp.exc"
_DEG = np.pi / 180.0
build = isg.build
constants = isg.constants


def render(tables: list[ControlTable], model: CompensationModel) -> dict:
    """File name -> text: ``volcomp.exc`` and ``volcomp.lis`` (and any ``ssfk_*.lis``)."""
    files = isg.render(tables, model)
    del files["volcomp.csv"]
    lines = [f"// mtmetrology export: {model.machine.name}, errors in mm and rad (Vendor)"]
    for name, value in isg.constants(model):
        lines += [f"[{name[2:]}]", f"VALUE = {-value:.12g}"]
    for t in tables:
        if not np.array_equal(t.forward, t.reverse):
            continue  # carried by its bilateral SSFK list
        s = 1.0 if t.axis in LINEAR_AXES else _DEG
        lines += [f"[{t.function.replace('_', '')}]", "Gridpoints = {"]
        lines += [f"    {q / s:.6f} {-c:.12g}" for q, c in zip(t.positions, t.forward, strict=True)]
        lines.append(f"}}  // end of {t.function.replace('_', '')}")
    files[FILE] = "\n".join(lines) + "\n"
    files["volcomp.lis"] = files["volcomp.lis"].replace(
        "file[0] volcomp.csv\nfile_format[0] ISG_CSV",
        f"file[0] {FILE}\nfile_format[0] ETALON_EXCHANGE",
    )
    return files
