"""Siemens Sinumerik interpolatory compensation: ``$AA_ENC_COMP`` and ``$AN_CEC`` tables.

Format (SINUMERIK *Function Manual Extended Functions*, 03/2013, 6FC5397-1BP40-3BA1,
K3 "Compensations", §4.4 "Interpolatory compensation"):

- measuring-system error compensation, pp. 240–242: ``$AA_ENC_COMP[e,N,AX]`` value of
  point N, ``$AA_ENC_COMP_STEP``, ``_MIN``, ``_MAX``, ``_IS_MODULO``; at most
  MD38000 ``$MA_MM_ENC_COMP_MAX_POINTS`` points; the first and last values stay active
  beyond the ends;
- sag / angularity (cross) compensation, pp. 248–249: ``$AN_CEC[t,N]`` with
  ``_INPUT_AXIS`` (basic axis), ``_OUTPUT_AXIS`` (compensation axis), ``_STEP``, ``_MIN``,
  ``_MAX``, ``_DIRECTION`` (0 both, 1 positive, −1 negative travel of the basic axis; two
  tables make a direction-dependent compensation, example p. 264), ``_MULT_BY_TABLE``,
  ``_IS_MODULO``; at most MD18342 ``$MN_MM_CEC_MAX_POINTS`` points (828D: 200, fixed);
- values in mm (degrees on a rotary axis), linear interpolation between equally spaced
  points (p. 237), the value added to the axis position (a correction, −E).

Carried: positioning errors ``E_XX`` … through ``$AA_ENC_COMP`` (both directions equal) or
two direction tables ``$AN_CEC``; straightness errors ``E_YX`` … through ``$AN_CEC`` with
input X and output Y.  Angular error functions cannot be carried: a table moves an axis.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.export._common import check_points, corrections, select
from mtmetrology.export.control import ControlTable
from mtmetrology.export.model import CompensationModel, ErrorTable
from mtmetrology.kinematics.topology import LINEAR_AXES

__all__ = ["MAX_POINTS", "build", "parse", "render"]

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


def render(tables: list[ControlTable], model: CompensationModel) -> dict:
    """File name -> text: ``ENC_COMP.INI`` (positioning) and ``CEC.INI`` (cross tables)."""
    enc = ["%_N_AX_EEC_INI", "CHANDATA(1)"]
    cec = ["%_N_NC_CEC_INI"]
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
            ax = t.axis
            enc += [f"$AA_ENC_COMP[0,{k},{ax}]={v / s:.6f}" for k, v in enumerate(t.forward)]
            enc += [
                f"$AA_ENC_COMP_STEP[0,{ax}]={step:.6f}",
                f"$AA_ENC_COMP_MIN[0,{ax}]={lo:.6f}",
                f"$AA_ENC_COMP_MAX[0,{ax}]={hi:.6f}",
                f"$AA_ENC_COMP_IS_MODULO[0,{ax}]={modulo}",
            ]
            continue
        directions = (0,) if np.array_equal(t.forward, t.reverse) else (1, -1)
        for d in directions:
            values = t.reverse if d < 0 else t.forward
            cec += [f"$AN_CEC[{t_index},{k}]={v:.6f}" for k, v in enumerate(values)]
            cec += [
                f"$AN_CEC_INPUT_AXIS[{t_index}]={t.axis}",
                f"$AN_CEC_OUTPUT_AXIS[{t_index}]={t.output}",
                f"$AN_CEC_STEP[{t_index}]={step:.6f}",
                f"$AN_CEC_MIN[{t_index}]={lo:.6f}",
                f"$AN_CEC_MAX[{t_index}]={hi:.6f}",
                f"$AN_CEC_DIRECTION[{t_index}]={d}",
                f"$AN_CEC_MULT_BY_TABLE[{t_index}]=0",
                f"$AN_CEC_IS_MODULO[{t_index}]={modulo}",
            ]
            t_index += 1
    return {
        "ENC_COMP.INI": "\n".join([*enc, "M17"]) + "\n",
        "CEC.INI": "\n".join([*cec, "M17"]) + "\n",
    }


_ASSIGN = re.compile(r"^\$(A[AN]_(?:ENC_COMP|CEC)\w*)\[([^\]]*)\]=(\S+)$")


def _grid(name: str, lo: float, hi: float, step: float, n: int, s: float) -> np.ndarray:
    q = lo + step * np.arange(n)
    if abs(q[-1] - hi) > 1e-6 * max(1.0, abs(hi)):
        raise InputError(f"{name}: _MAX {hi:g} is not _MIN + (points − 1) · _STEP")
    return q * s


def parse(files: dict) -> list[ControlTable]:
    """Read ``ENC_COMP.INI`` and ``CEC.INI`` texts back into tables (inverse of render)."""
    enc: dict[str, dict] = {}
    cec: dict[int, dict] = {}
    for fname in ("ENC_COMP.INI", "CEC.INI"):
        for k, line in enumerate(files.get(fname, "").splitlines(), start=1):
            if not line.startswith("$"):
                continue
            m = _ASSIGN.match(line.strip())
            if m is None:
                raise InputError(f"{fname}, line {k}: cannot read {line!r}")
            var, idx, value = m.group(1), m.group(2).split(","), m.group(3)
            if var.startswith("AA_ENC_COMP"):
                d = enc.setdefault(idx[-1], {"values": {}})
                if var == "AA_ENC_COMP":
                    d["values"][int(idx[1])] = float(value)
                else:
                    d[var[len("AA_ENC_COMP_") :]] = float(value)
            else:
                d = cec.setdefault(int(idx[0]), {"values": {}})
                if var == "AN_CEC":
                    d["values"][int(idx[1])] = float(value)
                else:
                    key = var[len("AN_CEC_") :]
                    d[key] = value if key.endswith("AXIS") else float(value)
    out = []
    for axis, d in enc.items():
        s = _unit(axis)
        v = np.array([d["values"][k] for k in sorted(d["values"])]) * s
        q = _grid(f"ENC_COMP {axis}", d["MIN"], d["MAX"], d["STEP"], v.size, s)
        period = 2 * np.pi if d["IS_MODULO"] else None
        out.append(ControlTable(f"E_{axis}{axis}", q, v, v, "linear", period))
    pending: dict[str, dict] = {}
    for _, d in sorted(cec.items()):
        axis, output = d["INPUT_AXIS"], d["OUTPUT_AXIS"]
        v = np.array([d["values"][k] for k in sorted(d["values"])])
        q = _grid(f"CEC {axis}->{output}", d["MIN"], d["MAX"], d["STEP"], v.size, _unit(axis))
        period = 2 * np.pi if d["IS_MODULO"] else None
        entry = pending.setdefault(f"E_{output}{axis}", {"q": q, "period": period})
        if d["DIRECTION"] == 0:
            entry["fwd"] = entry["rev"] = v
        elif d["DIRECTION"] > 0:
            entry["fwd"] = v
        else:
            entry["rev"] = v
    for f, e in pending.items():
        out.append(ControlTable(f, e["q"], e["fwd"], e["rev"], "linear", e["period"]))
    return out
