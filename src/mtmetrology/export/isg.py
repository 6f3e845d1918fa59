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

Semantics
---------
- **What a value means** (TF5280 overview): the compensation "is based on a parametric
  machine model that is standardised to the standards DIN ISO 230-1/7"; "The purpose of
  compensation is to balance out errors in tool positioning and orientation by correcting
  the axis setpoints".  The values written are the ISO 230-1 *errors* (names without
  ``E_``/underscores, lengths in mm, angles in rad, rotary arguments in degrees); the kernel
  computes the tool-point error from them and corrects it.  This carries every error
  function and the location errors for one direction (the forward values); linear
  interpolation in the argument, no direction dependence.
- **chain** (P-VOLC-00007): "The 6 axes available X, Y, Z, A, B and C can be used in any
  order", example ``chain XYZCA``; **workpiece_axes** (P-VOLC-00008): "how many axes in the
  kinematic chain lie on the workpiece side".  We write the machine's axes from the
  workpiece to the tool (the topology string without W, F, T and the spindle) and their
  count on the workpiece side.
- **negate** (P-VOLC-00009): "the Cartesian axes for which the compensation value is to be
  negated", a set of axis letters (``negate XY``), default "-".  The values are errors as
  the kernel expects, so nothing is negated and no ``negate`` line is written.
- **Axis lines**: ``X 1``, ``Y 2`` … as in the documentation's list example.
- The emulation the export's residual comes from is
  :mod:`mtmetrology.export.emulation.isg`.

Per-direction tables: an axis's own positioning error with a reversal term (``E_XXb``) is
written instead as a bilateral leadscrew error compensation list (SSFK, ``ssfk_x.lis``;
Beckhoff Information System TF5200 *Axis compensation*, "Leadscrew error compensation
(kw.ssfk.*)", P-COMP-00018 ``interval``, ``kw_startpos``, ``kw_nr_max``, ``unit``,
``bilateral``, P-COMP-00023/00024 ``table[i].pos`` / ``table[i].neg``, and the example
"Non-equidistant bilateral SSFK", infosys.beckhoff.com/content/1033/tf5200_axis_compensation/
308695435.html; activated per axis by P-AXIS-00175 ``lr_param.ssfk``): equidistant points,
values ``Δs = s_actual − s_set`` (the error) in 0.1 µm (0.0001° on a rotary axis) for the
positive and the negative direction, interpolated linearly.  That function is then left out
of ``volcomp.csv`` so it is not compensated twice.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.export._common import corrections, select
from mtmetrology.export.control import ControlTable
from mtmetrology.export.model import CompensationModel, ErrorTable
from mtmetrology.kinematics.topology import LINEAR_AXES

__all__ = ["build", "constants", "render"]

NAME = "isg"
_DEG = np.pi / 180.0


def _carries(table: ErrorTable) -> str | None:
    return None


def build(model: CompensationModel, functions: Sequence[str] | None = None) -> list[ControlTable]:
    """Tables of corrections the control applies (linear interpolation): the volumetric
    compensation's (forward), and bilateral SSFK tables for own-axis positioning errors with
    a reversal term."""
    out = []
    for t in select(model, _carries, functions, NAME):
        fwd, rev = corrections(model, t)
        if not (t.component == t.axis and t.bidirectional):
            rev = fwd
        out.append(ControlTable(t.function, t.positions, fwd, rev, "linear"))
    return out


def _ssfk_unit(axis: str) -> float:
    """0.1 µm in mm, or 0.0001° in rad."""
    return 1e-4 if axis in LINEAR_AXES else 1e-4 * _DEG


def _render_ssfk(t: ControlTable) -> str:
    unit = _ssfk_unit(t.axis)
    n = t.positions.size
    lines = [
        f"# mtmetrology export: bilateral leadscrew error compensation of {t.axis} "
        "(activate with lr_param.ssfk 1); errors s_actual - s_set in 0.1 um / 0.0001 deg",
        f"kopf.log_achs_name {t.axis}",
        f"kw.ssfk.interval {round((t.positions[1] - t.positions[0]) / unit)}",
        f"kw.ssfk.kw_startpos {round(t.positions[0] / unit)}",
        f"kw.ssfk.kw_nr_max {n}",
        "kw.ssfk.unit 1",
        "kw.ssfk.bilateral 1",
    ]
    lines += [f"kw.ssfk.table[{k}].pos {round(-t.forward[k] / unit)}" for k in range(n)]
    lines += [f"kw.ssfk.table[{k}].neg {round(-t.reverse[k] / unit)}" for k in range(n)]
    return "\n".join(lines) + "\n"


def constants(model: CompensationModel) -> tuple[tuple[str, float], ...]:
    """The location errors the control corrects: (name, correction), internal units."""
    return tuple((name, -model.sign * v) for name, v in model.constants)


def render(tables: list[ControlTable], model: CompensationModel) -> dict:
    """File name -> text: ``volcomp.csv`` (ISG_CSV) and ``volcomp.lis``."""
    lines = [f"// mtmetrology export: {model.machine.name}, errors in mm and rad"]
    if model.constants:
        lines.append(" ".join(n[2:] for n, _ in model.constants))
        lines.append(" ".join(f"{-v:.9g}" for _, v in constants(model)))
    files = {}
    for t in tables:
        if not np.array_equal(t.forward, t.reverse):
            files[f"ssfk_{t.axis.lower()}.lis"] = _render_ssfk(t)
    volcomp = [t for t in tables if np.array_equal(t.forward, t.reverse)]
    for axis in dict.fromkeys(t.axis for t in volcomp):
        group = [t for t in volcomp if t.axis == axis]
        s = 1.0 if axis in LINEAR_AXES else _DEG
        q = group[0].positions
        if any(not np.array_equal(t.positions, q) for t in group):
            raise InputError(f"axis {axis}: ISG_CSV needs one grid for all functions of an axis")
        lines.append("#")
        lines.append(" ".join([axis, *(t.function.replace("_", "") for t in group)]))
        for k in range(q.size):
            lines.append(" ".join([f"{q[k] / s:.6f}", *(f"{-t.forward[k]:.9g}" for t in group)]))
    topo = model.machine.topology
    # the chain from the workpiece to the tool: the topology string read from W to T
    chain = "".join(a for a in topo.string if a in "XYZABC")
    lis = [
        "# mtmetrology export: ISG Volumetric Compensation list file",
        *(f"{a} {i + 1}" for i, a in enumerate(model.machine.axis_names) if a != "S"),
        f"chain {chain}",
        f"workpiece_axes {sum(a != 'S' for a in topo.workpiece_axes)}",
        "file[0] volcomp.csv",
        "file_format[0] ISG_CSV",
    ]
    files["volcomp.csv"] = "\n".join(lines) + "\n"
    files["volcomp.lis"] = "\n".join(lis) + "\n"
    return files
