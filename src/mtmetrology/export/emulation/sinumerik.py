"""SINUMERIK interpolatory compensation, emulated from Siemens' manual: where the axis goes.

Semantics
---------
SINUMERIK 840D sl / 828D *Extended Functions*, Function Manual 03/2013,
6FC5397-1BP40-3BA1, K3 "Compensations", §4.4 "Interpolatory compensation".

- **Measuring-system error compensation, ``$AA_ENC_COMP``** (§4.4.2.1, p. 238): "The
  principle of the MSEC is to modify the axis-specific position actual value by the
  assigned compensation value … A positive compensation value causes the corresponding
  machine axis to move in the negative direction."  The table therefore holds the *error*
  of the axis: a value +E moves the axis by −E.  ``$AA_ENC_COMP[e,N,AX]`` is the value of
  point N of encoder e of machine axis AX (the example, p. 242, indexes by the machine-axis
  name ``X1``); values in mm (degrees on a rotary axis).
- **Sag / angularity compensation, ``$AN_CEC``** (§4.4.3, pp. 246–249): the table's
  output is applied to the compensation axis ``$AN_CEC_OUTPUT_AXIS`` as a function of the
  *setpoint* of the basic axis ``$AN_CEC_INPUT_AXIS`` (p. 248: "Name of machine axis whose
  setpoint is to be used as the input"); the total compensation value of an axis is the sum
  of its tables.  ``$AN_CEC_DIRECTION`` 0: both directions of travel of the basic axis,
  1: positive only, −1: negative only (p. 249).  How the sign of the value acts on the
  compensation axis is stated for the MSEC only; see :data:`SEMANTICS`.
- **Interpolation** (p. 237): linear between equally spaced interpolation points
  ``_MIN + N · _STEP``; ``_MAX`` must equal the last point.
- **Outside the table** (p. 248): "The compensation value of interpolation point 0 is used
  for all positions smaller than the initial position … of interpolation point <k> … for
  all positions larger than the end position (exception: table with modulo functions)";
  ``_IS_MODULO = 1`` repeats the table cyclically.

This module is the check of :mod:`mtmetrology.export.siemens`; it shares no code with it.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.export.control import ControlTable

__all__ = ["SEMANTICS", "load"]

_DEG = np.pi / 180.0
#: One assignment per line: ``$AA_ENC_COMP[0,12,X1]=0.0031`` or ``$AN_CEC_INPUT_AXIS[0]=(AX1)``.
_ASSIGN = re.compile(r"^\$(A[AN]_(?:ENC_COMP|CEC)\w*)\s*\[([^\]]*)\]\s*=\s*(\S+)")

SEMANTICS = {
    "ENC_COMP": {
        "value": "error",
        "sign_established": True,
        "source": (
            "SINUMERIK K3, 6FC5397-1BP40-3BA1 (03/2013), §4.4.2.1 p. 238: 'A positive "
            "compensation value causes the corresponding machine axis to move in the negative "
            "direction.'"
        ),
    },
    "CEC": {
        "value": "error",
        "sign_established": False,
        "source": (
            "SINUMERIK K3 §4.4.3 (pp. 246-249) names the tables, axes and directions but no "
            "sentence ties the sign of $AN_CEC to the motion of the compensation axis; taken "
            "as for the MSEC (a positive value moves the compensation axis negatively)"
        ),
    },
}


def _unit(axis: str) -> float:
    """mm on a linear axis, degrees on a rotary one, in internal units."""
    return 1.0 if axis in "XYZ" else _DEG


def _axis(name: str, value: str, axes: Mapping[str, str], where: str) -> str:
    """The machine axis of a control axis name (``X1``, ``(AX1)``)."""
    key = value.strip().strip("()")
    if key not in axes:
        raise InputError(
            f"{where}: {name} {value!r} is not a machine axis of the map "
            f"({', '.join(sorted(axes))})"
        )
    return axes[key]


def _points(where: str, d: dict, q_scale: float, v_scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Positions and values (internal units) of a table from its ``_MIN``, ``_STEP``,
    ``_MAX`` and values; ``q_scale`` and ``v_scale`` convert the input axis's and the
    compensated axis's unit (1 for mm, π/180 for degrees)."""
    for key in ("MIN", "MAX", "STEP"):
        if key not in d:
            raise InputError(f"{where}: no _{key}")
    values = d["values"]
    n = max(values) + 1
    missing = sorted(set(range(n)) - set(values))
    if missing:
        raise InputError(f"{where}: no value for interpolation point {missing[0]}")
    lo, hi, step = d["MIN"], d["MAX"], d["STEP"]
    if step <= 0:
        raise InputError(f"{where}: _STEP {step:g} is not positive")
    if abs(lo + (n - 1) * step - hi) > 1e-6 * max(1.0, abs(hi)):
        raise InputError(f"{where}: _MAX {hi:g} is not _MIN + (points - 1) * _STEP")
    q = (lo + step * np.arange(n)) * q_scale
    v = np.array([values[k] for k in range(n)]) * v_scale
    return q, v


def load(files: Mapping[str, str], axes: Mapping[str, str]) -> list[ControlTable]:
    """The displacement the control gives each axis, from ``ENC_COMP.INI`` and ``CEC.INI``.

    Parameters
    ----------
    files : mapping of file name to text
    axes : mapping of control machine-axis name to machine axis
        e.g. ``{"X1": "X", "Y1": "Y", "Z1": "Z"}``; a rotary axis is in degrees.

    Returns
    -------
    list of ControlTable
        ``E_XX`` for an MSEC table of X (displacement −value); ``E_YX`` for CEC tables with
        basic axis X and compensation axis Y (displacement −value, :data:`SEMANTICS`); the
        tables of one pair are summed, per direction.

    Raises
    ------
    InputError
        A line that is not an assignment, an unknown axis, a grid whose ``_MAX`` does not
        follow from ``_MIN`` and ``_STEP``, a missing point.
    """
    enc: dict[str, dict] = {}
    cec: dict[int, dict] = {}
    for fname in ("ENC_COMP.INI", "CEC.INI"):
        for k, raw in enumerate(files.get(fname, "").splitlines(), start=1):
            line = raw.split(";", 1)[0].strip()
            if not line.startswith("$"):
                continue  # %_N_… header, CHANDATA(1), M17
            m = _ASSIGN.match(line)
            if m is None:
                raise InputError(f"{fname}, line {k}: cannot read {raw!r}")
            var, index, value = m.group(1), [s.strip() for s in m.group(2).split(",")], m.group(3)
            where = f"{fname}, line {k}"
            try:
                if var.startswith("AA_ENC_COMP"):
                    axis = _axis("axis", index[-1], axes, where)
                    d = enc.setdefault(axis, {"values": {}})
                    if var == "AA_ENC_COMP":
                        d["values"][int(index[1])] = float(value)
                    else:
                        d[var[len("AA_ENC_COMP_") :]] = float(value)
                else:
                    d = cec.setdefault(int(index[0]), {"values": {}})
                    key = var[len("AN_CEC_") :] if var != "AN_CEC" else None
                    if key is None:
                        d["values"][int(index[1])] = float(value)
                    elif key.endswith("AXIS"):
                        d[key] = _axis(key, value, axes, where)
                    else:
                        d[key] = float(value)
            except InputError:
                raise
            except (ValueError, IndexError):
                raise InputError(f"{where}: cannot read {raw!r}") from None
    out = []
    for axis, d in enc.items():
        scale = _unit(axis)
        q, v = _points(f"ENC_COMP.INI, axis {axis}", d, scale, scale)
        period = 2 * np.pi if d.get("IS_MODULO", 0) else None
        out.append(ControlTable(f"E_{axis}{axis}", q, -v, -v, "linear", period))
    pairs: dict[str, dict] = {}
    for t, d in sorted(cec.items()):
        where = f"CEC.INI, table {t}"
        for key in ("INPUT_AXIS", "OUTPUT_AXIS"):
            if key not in d:
                raise InputError(f"{where}: no $AN_CEC_{key}")
        basic, output = d["INPUT_AXIS"], d["OUTPUT_AXIS"]
        # positions in the basic axis's unit, values in the compensation axis's
        q, v = _points(where, d, _unit(basic), _unit(output))
        direction = int(d.get("DIRECTION", 0))
        if direction not in (-1, 0, 1):
            raise InputError(f"{where}: $AN_CEC_DIRECTION {direction} is not -1, 0 or 1")
        period = 2 * np.pi if d.get("IS_MODULO", 0) else None
        entry = pairs.setdefault(f"E_{output}{basic}", {"q": q, "period": period})
        if not np.array_equal(entry["q"], q):
            raise InputError(f"{where}: tables of one axis pair must share their points")
        for sense, applies in (("forward", direction >= 0), ("reverse", direction <= 0)):
            if applies:
                entry[sense] = entry.get(sense, 0.0) - v
    for function, e in pairs.items():
        fwd = e.get("forward", np.zeros_like(e["q"]))
        rev = e.get("reverse", np.zeros_like(e["q"]))
        out.append(ControlTable(function, e["q"], fwd, rev, "linear", e["period"]))
    return out
