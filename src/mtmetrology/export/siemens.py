"""Siemens Sinumerik interpolatory compensation: ``$AA_ENC_COMP`` and ``$AN_CEC`` tables.

Format (SINUMERIK *Function Manual Extended Functions*, 03/2013, 6FC5397-1BP40-3BA1,
K3 "Compensations", §4.4 "Interpolatory compensation"):

- measuring-system error compensation, pp. 238–242: ``$AA_ENC_COMP[e,N,AX]`` value of
  point N of encoder e of machine axis AX, ``$AA_ENC_COMP_STEP``, ``_MIN``, ``_MAX``,
  ``_IS_MODULO``; at most MD38000 ``$MA_MM_ENC_COMP_MAX_POINTS`` points; the first and last
  values stay active beyond the ends;
- sag / angularity (cross) compensation, pp. 246–249: ``$AN_CEC[t,N]`` with
  ``_INPUT_AXIS`` (basic axis), ``_OUTPUT_AXIS`` (compensation axis), ``_STEP``, ``_MIN``,
  ``_MAX``, ``_DIRECTION`` (0 both, 1 positive, −1 negative travel of the basic axis; two
  tables make a direction-dependent compensation, example p. 264), ``_MULT_BY_TABLE``,
  ``_IS_MODULO``; at most MD18342 ``$MN_MM_CEC_MAX_POINTS`` points (828D: 200, fixed);
- values in mm (degrees on a rotary axis), linear interpolation between equally spaced
  points (p. 237).

Semantics
---------
- **Sign of ``$AA_ENC_COMP``** (§4.4.2.1, p. 238): "The principle of the MSEC is to modify
  the axis-specific position actual value by the assigned compensation value … A positive
  compensation value causes the corresponding machine axis to move in the negative
  direction."  The table holds the *error* E of the axis (+E moves the axis by −E).
- **Sign of ``$AN_CEC``**: no sentence of K3 ties it to the motion of the compensation axis
  (pp. 246–249 fix the axes, the setpoint input, the directions and the end values).  The
  table holds +E as the MSEC does, and the export says "sign not established by the
  vendor's documentation", with the verification procedure.
- **Axis names**: the machine-axis names of K3's examples (``$AA_ENC_COMP[0,2,X1]``, p. 242;
  ``$AN_CEC_INPUT_AXIS[0]=(AX2)``), ``X1``, ``Y1``, ``Z1`` … by default; ``axis_names`` maps
  them to the machine's.
- **Outside the table** the values of the first and last points stay active; no
  direction dependence for the MSEC (its backlash is MD32450); ``_IS_MODULO`` on a rotary
  axis of one revolution.
- The emulation the export's residual comes from is
  :mod:`mtmetrology.export.emulation.sinumerik`, written from the same sentences.

Carried: positioning errors ``E_XX`` … through ``$AA_ENC_COMP`` (both directions equal) or
two direction tables ``$AN_CEC``; straightness errors ``E_YX`` … through ``$AN_CEC`` with
input X and output Y.  Angular error functions cannot be carried: a table moves an axis.
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

NAME = "siemens"
#: Default MD38000 / MD18342 (the 828D fixes 200 points per CEC table).
MAX_POINTS = 200
_DEG = np.pi / 180.0


def _carries(table: ErrorTable) -> str | None:
    if table.is_rotation:
        return "a Sinumerik table shifts an axis; an angular error function is not an axis shift"
    return None


def build(
    model: CompensationModel,
    functions: Sequence[str] | None = None,
    *,
    max_points: int = MAX_POINTS,
) -> list[ControlTable]:
    """Tables the control will apply (corrections, linear interpolation, modulo on ≥ 360°).

    Raises
    ------
    InputError
        More points than MD38000/MD18342, a rotational function asked for.
    """
    out = []
    for t in select(model, _carries, functions, NAME):
        check_points(NAME, t.function, t.positions.size, max_points, "MD38000 / MD18342")
        fwd, rev = corrections(model, t)
        travel = model.machine.axes[t.axis].travel
        period = None
        if t.axis not in LINEAR_AXES and abs(travel[1] - travel[0] - 2 * np.pi) < 1e-9:
            stop = round(2 * np.pi / t.pitch) + 1
            if abs(2 * np.pi / t.pitch - (stop - 1)) > 1e-9 or not np.allclose(
                fwd[0], fwd[stop - 1], atol=1e-7
            ):
                raise InputError(
                    f"{t.function}: _IS_MODULO: the values at 0 and 360° must be equal and the "
                    "pitch must divide 360°"
                )
            q, fwd, rev, period = t.positions[:stop], fwd[:stop], rev[:stop], 2 * np.pi
        else:
            q = t.positions
        out.append(ControlTable(t.function, q, fwd, rev, "linear", period))
    return out


def _unit(axis: str) -> float:
    return 1.0 if axis in LINEAR_AXES else _DEG


def render(
    tables: list[ControlTable], model: CompensationModel, *, axis_names: dict | None = None
) -> dict:
    """File name -> text: ``ENC_COMP.INI`` (positioning) and ``CEC.INI`` (cross tables).

    The tables hold corrections (what the axis must move); the files hold the errors, the
    negated corrections (module Semantics).  ``axis_names`` maps the machine's axes to the
    control's machine-axis names (``{"X": "X1", …}``, the default).
    """
    names = {a: f"{a}1" for a in model.machine.axis_names} | dict(axis_names or {})
    enc = ["%_N_AX_EEC_INI", "CHANDATA(1)"]
    cec = ["%_N_NC_CEC_INI", "CHANDATA(1)"]
    t_index = 0
    for t in tables:
        s = _unit(t.axis)
        modulo = int(t.period is not None)
        lo, hi, step = (
            t.positions[0] / s,
            t.positions[-1] / s,
            (t.positions[1] - t.positions[0]) / s,
        )
        if t.output == t.axis and np.array_equal(t.forward, t.reverse):
            ax = names[t.axis]
            enc += [f"$AA_ENC_COMP[0,{k},{ax}]={-v / s:.6f}" for k, v in enumerate(t.forward)]
            enc += [
                f"$AA_ENC_COMP_STEP[0,{ax}]={step:.6f}",
                f"$AA_ENC_COMP_MIN[0,{ax}]={lo:.6f}",
                f"$AA_ENC_COMP_MAX[0,{ax}]={hi:.6f}",
                f"$AA_ENC_COMP_IS_MODULO[0,{ax}]={modulo}",
            ]
            continue
        directions = (0,) if np.array_equal(t.forward, t.reverse) else (1, -1)
        out_unit = _unit(t.output)
        for d in directions:
            values = t.reverse if d < 0 else t.forward
            cec += [f"$AN_CEC[{t_index},{k}]={-v / out_unit:.6f}" for k, v in enumerate(values)]
            cec += [
                f"$AN_CEC_INPUT_AXIS[{t_index}]=({names[t.axis]})",
                f"$AN_CEC_OUTPUT_AXIS[{t_index}]=({names[t.output]})",
                f"$AN_CEC_STEP[{t_index}]={step:.6f}",
                f"$AN_CEC_MIN[{t_index}]={lo:.6f}",
                f"$AN_CEC_MAX[{t_index}]={hi:.6f}",
                f"$AN_CEC_DIRECTION[{t_index}]={d}",
                f"$AN_CEC_MULT_BY_TABLE[{t_index}]=0",
                f"$AN_CEC_IS_MODULO[{t_index}]={modulo}",
            ]
            t_index += 1
    files = {}
    if len(enc) > 2:
        files["ENC_COMP.INI"] = "\n".join([*enc, "M17"]) + "\n"
    if t_index:
        files["CEC.INI"] = "\n".join([*cec, "M17"]) + "\n"
    return files
