"""ISG kernel compensation (Beckhoff TwinCAT CNC), emulated from ISG's documentation.

Semantics
---------
Beckhoff Information System, TF5280 *Volumetric Compensation* and TF5200 *Volumetric
compensation parameters* (the ISG kernel documentation); TF5200 *Axis compensation*,
"Leadscrew error compensation (kw.ssfk.*)".

Volumetric compensation (``volcomp.lis`` with ``volcomp.csv`` or ``volcomp.exc``):

- **What a value means.** TF5280 overview: the compensation "is based on a parametric
  machine model that is standardised to the standards DIN ISO 230-1/7"; "The purpose of
  compensation is to balance out errors in tool positioning and orientation by correcting
  the axis setpoints"; "Volumetric Compensation only compensates for tool position."  The
  files hold the ISO 230-1 *error* parameters (``EXX`` … as functions of an axis argument,
  location errors ``C0Y`` … as values), lengths in mm, angles in rad, rotary arguments in
  degrees; the kernel computes the tool-point error from them through its kinematic chain
  and corrects the setpoints by its negative.
- **Chain** (P-VOLC-00007 ``chain``): "The 6 axes available X, Y, Z, A, B and C can be used
  in any order"; example "chain XYZCA" (a conventional CA machine, every axis on the tool
  side).  P-VOLC-00008 ``workpiece_axes``: "how many axes in the kinematic chain lie on the
  workpiece side", 0 ≤ n < 6, default 0.  We read the chain from the workpiece to the tool
  (the example's axes on the tool side are listed from the frame to the tool); the kernel's
  tool-point error is computed here through the machine's own chain, so the emulation
  refuses a ``.lis`` whose chain is not the machine's.
- **negate** (P-VOLC-00009): "the Cartesian axes for which the compensation value is to be
  negated … the value "XY" means that the compensation values for X and Y are to be negated,
  but not for Z"; default "-" (none).  ``set_to_zero`` likewise sets them to 0.
- **Between the data**: linear interpolation in the argument ("ISG CSV format");
  **outside** it the end values are held (as the crosscomp2 pages state: "Außerhalb der
  Tabelle bleiben die Korrekturwerte am Tabellenrand wirksam"); no direction dependence.

Leadscrew error compensation (``ssfk_*.lis``):

- **What a value means.** "Compensation values are specified as absolute position errors in
  the unit specified in P-COMP-00017" (0.1 µm on a linear axis, 0.0001° on a rotary one);
  the example "Non-equidistant bilateral SSFK" computes them as ``Δs_i = s_ist,i − s_soll,i``:
  set point 19866.7 µm, measured 19856.5 µm → −102 (×0.1 µm).  "The position setpoint of the
  compensated axis is changed by a compensation value … in order to compensate for leadscrew
  errors": the setpoint is corrected by −Δs.
- **Between points** "The compensation value is linearly interpolated"; equidistant points
  from ``kw_startpos`` every ``interval``; the end values are held beyond the table.
- **Direction**: ``bilateral 1``: ``table[i].pos`` for motion in the positive direction,
  ``table[i].neg`` for the negative one.

This module is the check of :mod:`mtmetrology.export.isg` and
:mod:`mtmetrology.export.etalon`; it shares no code with them.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.export.control import ControlTable

__all__ = ["SEMANTICS", "load"]

_DEG = np.pi / 180.0

SEMANTICS = {
    "value": "error",
    "sign_established": True,
    "source": (
        "Beckhoff TF5280 Volumetric Compensation: ISO 230-1 error parameters, the kernel "
        "corrects the setpoints; TF5200 Axis compensation, leadscrew error compensation: "
        "'absolute position errors', example Δs = s_ist − s_soll (19856.5 − 19866.7 µm = "
        "−102 × 0.1 µm)"
    ),
}


def _lis(text: str) -> dict:
    """The ``.lis`` settings the emulation uses: ``chain``, ``workpiece_axes``, ``negate``,
    ``set_to_zero`` (documented defaults) and the files with their formats."""
    settings = {"chain": "XYZ", "workpiece_axes": 0, "negate": "", "set_to_zero": ""}
    files: dict[int, dict] = {}
    for k, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        try:
            key, value = line.split(None, 1)
        except ValueError:
            raise InputError(f"volcomp.lis, line {k}: cannot read {raw!r}") from None
        value = value.strip()
        if key in ("chain", "negate", "set_to_zero"):
            letters = "" if value == "-" else value
            if not letters or set(letters) - set("XYZABC") or len(set(letters)) != len(letters):
                raise InputError(
                    f"volcomp.lis, line {k}: {key} {value!r}: only the axis letters X, Y, Z, "
                    "A, B, C, each at most once (P-VOLC-00007 / P-VOLC-00009)"
                )
            if key != "chain" and set(letters) - set("XYZ"):
                raise InputError(f"volcomp.lis, line {k}: {key} {value!r}: Cartesian axes only")
            settings[key] = letters
        elif key == "workpiece_axes":
            if not value.isdigit() or not 0 <= int(value) < 6:
                raise InputError(f"volcomp.lis, line {k}: workpiece_axes {value!r}: 0 to 5")
            settings[key] = int(value)
        elif key.startswith(("file[", "file_format[")) and key.endswith("]"):
            name, index = key[:-1].split("[")
            files.setdefault(int(index), {})[name] = value
    settings["files"] = [files[j] for j in sorted(files)]
    return settings


def _numbers(where: str, values) -> np.ndarray:
    try:
        return np.array(values, dtype=float)
    except ValueError:
        raise InputError(f"{where}: a value is not a number") from None


def _csv(name: str, text: str) -> tuple[list, list]:
    """Tables ``(function, argument axis, arguments, values)`` and location errors."""
    blocks: list[list[tuple[int, list[str]]]] = [[]]
    for k, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("//", 1)[0].strip()
        if not line:
            continue
        if line.startswith("#"):
            blocks.append([])
        else:
            blocks[-1].append((k, line.split()))
    tables, locations = [], []
    for block in blocks:
        if not block:
            continue
        (k, header), rows = block[0], block[1:]
        data = _numbers(f"{name}, block at line {k}", [r for _, r in rows])
        if data.ndim != 2 or data.shape[1] != len(header):
            raise InputError(f"{name}, line {k}: rows do not match the header {header}")
        if header[0] in ("X", "Y", "Z", "A", "B", "C"):
            for j, parameter in enumerate(header[1:], start=1):
                tables.append((parameter, header[0], data[:, 0], data[:, j]))
        else:
            if data.shape[0] != 1:
                raise InputError(f"{name}, line {k}: location errors take one data row")
            locations += list(zip(header, data[0], strict=True))
    return tables, locations


def _exc(name: str, text: str) -> tuple[list, list]:
    """The Etalon exchange file: ``[EXY]`` ``Gridpoints = {`` … ``}`` and ``[C0B]`` ``VALUE``."""
    tables, locations = [], []
    block, rows = None, None
    for k, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("//", 1)[0].strip()
        if not line:
            continue
        compact = line.replace(" ", "")
        if line.startswith("[") and line.endswith("]") and rows is None:
            block = line[1:-1]
        elif compact.startswith("VALUE=") and block is not None:
            locations.append((block, float(_numbers(f"{name}, line {k}", compact[6:]))))
        elif compact == "Gridpoints={" and block is not None:
            rows = []
        elif line.startswith("}") and rows is not None:
            data = _numbers(f"{name}, table [{block}]", rows)
            tables.append((block, block[2], data[:, 0], data[:, 1]))
            rows = None
        elif rows is not None and len(line.split()) == 2:
            rows.append(line.split())
        else:
            raise InputError(f"{name}, line {k}: cannot read {raw!r}")
    if rows is not None:
        raise InputError(f"{name}: table [{block}] is not closed with '}}'")
    return tables, locations


def _ssfk(name: str, text: str) -> ControlTable:
    entries: dict[str, str] = {}
    for k, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        parts = line.split(None, 1)
        if len(parts) != 2:
            raise InputError(f"{name}, line {k}: cannot read {raw!r}")
        entries[parts[0]] = parts[1].strip()

    def number(key: str) -> int:
        if key not in entries:
            raise InputError(f"{name}: no {key}")
        try:
            return int(entries[key])
        except ValueError:
            raise InputError(f"{name}: {key} {entries[key]!r} is not an integer") from None

    axis = entries.get("kopf.log_achs_name", "")
    if axis not in ("X", "Y", "Z", "A", "B", "C"):
        raise InputError(f"{name}: kopf.log_achs_name {axis!r} is not an axis of the machine")
    if number("kw.ssfk.unit") != 1:
        raise InputError(f"{name}: kw.ssfk.unit 0 (encoder increments) cannot be checked")
    unit = 1e-4 if axis in "XYZ" else 1e-4 * _DEG  # 0.1 µm in mm, 0.0001° in rad
    n, interval = number("kw.ssfk.kw_nr_max"), number("kw.ssfk.interval")
    if interval <= 0:
        raise InputError(f"{name}: kw.ssfk.interval {interval}: equidistant tables only")
    q = (number("kw.ssfk.kw_startpos") + interval * np.arange(n)) * unit
    pos = np.array([number(f"kw.ssfk.table[{i}].pos") for i in range(n)]) * unit
    neg = pos
    if number("kw.ssfk.bilateral") == 1:
        neg = np.array([number(f"kw.ssfk.table[{i}].neg") for i in range(n)]) * unit
    # the setpoint is corrected by −Δs (module notes)
    return ControlTable(f"E_{axis}{axis}", q, -pos, -neg, "linear")


def load(
    files: Mapping[str, str], chain: str, workpiece_axes: int
) -> tuple[list[ControlTable], tuple[tuple[str, float], ...], np.ndarray]:
    """What the ISG kernel corrects, from ``volcomp.lis``, its data file and ``ssfk_*.lis``.

    Parameters
    ----------
    files : mapping of file name to text
    chain : str
        The machine's axes from the workpiece to the tool (``"XYZ"``), with
        ``workpiece_axes`` of them on the workpiece side: the ``.lis`` must state the same.

    Returns
    -------
    tables : list of ControlTable
        Per error function, the correction of the function (−value), linear, end values
        held; per SSFK list, the correction of the axis's setpoint per direction.
    constants : tuple of (str, float)
        Location errors and their corrections (``("E_C0Y", −value)``).
    factors : ndarray, shape (3,)
        Per Cartesian axis: −1 where ``negate`` names it, 0 where ``set_to_zero`` does, 1
        otherwise.

    Raises
    ------
    InputError
        A ``.lis`` setting outside its documented range, a chain other than the machine's,
        a data file that cannot be read.
    """
    tables: list[ControlTable] = []
    constants: tuple[tuple[str, float], ...] = ()
    factors = np.ones(3)
    if "volcomp.lis" in files:
        settings = _lis(files["volcomp.lis"])
        if (settings["chain"], settings["workpiece_axes"]) != (chain, workpiece_axes):
            raise InputError(
                f"volcomp.lis: chain {settings['chain']} with workpiece_axes "
                f"{settings['workpiece_axes']} is not the machine's chain {chain} with "
                f"{workpiece_axes} workpiece-side axes"
            )
        for c, letter in enumerate("XYZ"):
            factors[c] = -1.0 if letter in settings["negate"] else 1.0
            factors[c] *= 0.0 if letter in settings["set_to_zero"] else 1.0
        for entry in settings["files"]:
            name, fmt = entry.get("file"), entry.get("file_format")
            if name not in files:
                raise InputError(f"volcomp.lis: file {name!r} not given")
            if fmt == "ISG_CSV":
                rows, locations = _csv(name, files[name])
            elif fmt == "ETALON_EXCHANGE":
                rows, locations = _exc(name, files[name])
            else:
                raise InputError(f"volcomp.lis: file_format {fmt!r} of {name}")
            for parameter, axis, arguments, values in rows:
                if len(parameter) != 3 or parameter[0] != "E" or parameter[2] != axis:
                    raise InputError(f"{name}: {parameter} is not an error function of {axis}")
                scale = 1.0 if axis in "XYZ" else _DEG
                q = arguments * scale
                tables.append(ControlTable(f"E_{parameter[1:]}", q, -values, -values, "linear"))
            constants += tuple((f"E_{n}", -float(v)) for n, v in locations)
    for name in sorted(files):
        if name.startswith("ssfk_") and name.endswith(".lis"):
            tables.append(_ssfk(name, files[name]))
    return tables, constants, factors
