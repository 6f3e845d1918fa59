"""ISG kernel Volumetric Compensation: the ``ISG_CSV`` parameter file and its ``.lis`` list.

Format (Beckhoff Information System, TF5280 *Volumetric Compensation* — the ISG kernel
documentation: "ISG CSV format", infosys.beckhoff.com/content/1033/tf5280_volumetric_comp/
296429067.html; "General configuration (obligatory)", …/296390283.html; the parameter list
TF5200 *Volumetric compensation parameters*, P-VOLC-00012 ``file[j]`` and P-VOLC-00013
``file_format[j]``, with ``chain``, ``workpiece_axes``, ``negate``, …/563009163.html):

- a header row names the columns: argument names (``X``) and parameter names; rows below
  are records; ``//`` starts a comment; ``#`` starts a new block with its own header;
- position errors of the machine (``Y0A Z0A X0B …``), typically one data row;
- component errors of an axis: argument ``X`` then ``EXX EYX EZX EAX EBX ECX``, one row per
  position; parameters are interpolated linearly in the argument;
- the ``.lis`` configuration names the axes, the kinematic ``chain``, the number of
  ``workpiece_axes``, ``negate`` (negate the compensation values) and the files.

The values written are the *errors* (ISO 230-1 names without ``E_``/underscores, lengths in
mm, angles in rad, rotary arguments in degrees) and ``negate 0``: the control computes the
tool-point error from them and corrects it.  This carries every error function and the
location errors; the reverse direction is not carried (the forward values are written).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.export._common import corrections, select
from mtmetrology.export.control import ControlTable
from mtmetrology.export.model import CompensationModel, ErrorTable
from mtmetrology.kinematics.topology import LINEAR_AXES

__all__ = ["build", "parse", "render"]

NAME = "isg"
_DEG = np.pi / 180.0


def _carries(table: ErrorTable) -> str | None:
    return None


def build(model: CompensationModel, functions: Sequence[str] | None = None) -> list[ControlTable]:
    """Tables of corrections the volumetric compensation applies (linear interpolation)."""
    out = []
    for t in select(model, _carries, functions, NAME):
        fwd, _ = corrections(model, t)
        out.append(ControlTable(t.function, t.positions, fwd, fwd, "linear"))
    return out


def constants(model: CompensationModel) -> tuple[tuple[str, float], ...]:
    """The location errors the control corrects: (name, correction), internal units."""
    return tuple((name, -model.sign * v) for name, v in model.constants)


def render(tables: list[ControlTable], model: CompensationModel) -> dict:
    """File name -> text: ``volcomp.csv`` (ISG_CSV) and ``volcomp.lis``."""
    lines = [f"// mtmetrology export: {model.machine.name}, errors in mm and rad"]
    if model.constants:
        lines.append(" ".join(n[2:] for n, _ in model.constants))
        lines.append(" ".join(f"{-v:.9g}" for _, v in constants(model)))
    for axis in dict.fromkeys(t.axis for t in tables):
        group = [t for t in tables if t.axis == axis]
        s = 1.0 if axis in LINEAR_AXES else _DEG
        q = group[0].positions
        if any(not np.array_equal(t.positions, q) for t in group):
            raise InputError(f"axis {axis}: ISG_CSV needs one grid for all functions of an axis")
        lines.append("#")
        lines.append(" ".join([axis, *(t.function.replace("_", "") for t in group)]))
        for k in range(q.size):
            lines.append(" ".join([f"{q[k] / s:.6f}", *(f"{-t.forward[k]:.9g}" for t in group)]))
    topo = model.machine.topology
    lis = [
        "# mtmetrology export: ISG Volumetric Compensation list file",
        *(f"{a.lower()} {i + 1}" for i, a in enumerate(model.machine.axis_names) if a != "S"),
        f"chain {topo.string}",
        f"workpiece_axes {len(topo.workpiece_axes)}",
        "negate 0",
        "file[0] volcomp.csv",
        "file_format[0] ISG_CSV",
    ]
    return {"volcomp.csv": "\n".join(lines) + "\n", "volcomp.lis": "\n".join(lis) + "\n"}


def parse(files: dict) -> tuple[list[ControlTable], tuple[tuple[str, float], ...]]:
    """Read ``volcomp.csv`` back: the tables and the location-error corrections."""
    blocks: list[list[list[str]]] = [[]]
    for line in files["volcomp.csv"].splitlines():
        if line.startswith("//") or not line.strip():
            continue
        if line.startswith("#"):
            blocks.append([])
        else:
            blocks[-1].append(line.split())
    tables, consts = [], ()
    for k, block in enumerate(blocks):
        if not block:
            continue
        header, rows = block[0], block[1:]
        try:
            data = np.array(rows, dtype=float)
        except ValueError:
            raise InputError(f"volcomp.csv, block {k}: a value is not a number") from None
        if data.ndim != 2 or data.shape[1] != len(header):
            raise InputError(f"volcomp.csv, block {k}: rows do not match the header {header}")
        if header[0] in "XYZABC" and len(header[0]) == 1:
            axis = header[0]
            q = data[:, 0] * (1.0 if axis in LINEAR_AXES else _DEG)
            for j, name in enumerate(header[1:], start=1):
                c = -data[:, j]
                tables.append(ControlTable(f"E_{name[1:]}", q, c, c, "linear"))
        else:
            consts = tuple((f"E_{n}", -float(v)) for n, v in zip(header, data[0], strict=True))
    return tables, consts
