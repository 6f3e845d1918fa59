"""The controls, emulated from their vendors' documents: what a control does with our files.

Each module reads the files of one control as that control's documentation (or, for an
open-source control, its source) says the control reads them, and returns what the control
applies: the displacement of each axis, or the correction of each error function of a
volumetric compensation, as a function of the commanded position and the sense of travel
(:class:`~mtmetrology.export.control.ControlTable`).  Each module's docstring quotes the
sentences it is written from, under "Semantics", with document, edition and page (or
repository, file and function).  No module here imports a writer: the residual the user
reads (:func:`mtmetrology.export.workflow.export_compensation`, ``check.json``) is what
this emulation leaves of the machine's error, so a writer that gets a sign wrong shows as a
residual of twice the error, not as zero.

- :mod:`~mtmetrology.export.emulation.linuxcnc` — ``compute_screw_comp``/``usrmotLoadComp``;
- :mod:`~mtmetrology.export.emulation.sinumerik` — K3 ``$AA_ENC_COMP`` and ``$AN_CEC``;
- :mod:`~mtmetrology.export.emulation.fanuc` — parameters 3620–3627 and the pitch data;
- :mod:`~mtmetrology.export.emulation.isg` — ``volcomp.lis`` (ISG_CSV, Etalon) and SSFK.

Where a vendor's document does not fix the sign, the module's ``SEMANTICS`` says so
(``sign_established`` false) and the export says it in words, with the verification
procedure that settles it on the machine.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.export.emulation import fanuc, isg, linuxcnc, sinumerik
from mtmetrology.kinematics.machine import Machine

__all__ = ["Emulation", "chain", "default_axis_names", "emulate", "joints"]

#: Words stated wherever a format's sign is not fixed by its vendor's documentation.
SIGN_NOT_ESTABLISHED = "sign not established by the vendor's documentation"


@dataclass(frozen=True)
class Emulation:
    """What a control applies after reading the files.

    Attributes
    ----------
    tables : list of ControlTable
        Displacements (or error-function corrections) as functions of the input axis.
    constants : tuple of (str, float)
        Location-error corrections of a volumetric compensation (internal units).
    factors : ndarray, shape (3,)
        Per Cartesian component of the tool-point correction: 1, −1 (negated) or 0.
    semantics : list of dict
        Per kind of file read: ``file``, ``value`` ("error" or "correction"),
        ``sign_established`` and ``source`` (the document and the sentence).
    """

    tables: list
    constants: tuple = ()
    factors: np.ndarray = field(default_factory=lambda: np.ones(3))
    semantics: list = field(default_factory=list)

    @property
    def sign_established(self) -> bool:
        """Whether every file's sign is fixed by the vendor's document."""
        return all(s["sign_established"] for s in self.semantics)


def chain(machine: Machine) -> tuple[str, int]:
    """The machine's axes from the workpiece to the tool, and how many are on the
    workpiece side (ISG ``chain``, ``workpiece_axes``); the spindle is not in it."""
    topo = machine.topology
    work = [a for a in reversed(topo.workpiece_axes) if a != "S"]
    tool = [a for a in topo.tool_axes if a != "S"]
    return "".join(work + tool), len(work)


def joints(machine: Machine) -> dict[str, str]:
    """LinuxCNC joint number -> machine axis: the joints in the machine's reading order."""
    axes = [a for a in machine.axis_names if a in "XYZABC"]
    return {str(j): a for j, a in enumerate(axes)}


def default_axis_names(machine: Machine) -> dict[str, str]:
    """Machine axis -> the Sinumerik machine-axis name of K3's examples (``X1``, ``Y1`` …)."""
    return {a: f"{a}1" for a in machine.axis_names if a in "XYZABC"}


def _semantics(file: str, s: dict) -> dict:
    return {"file": file, **s}


def emulate(
    fmt: str,
    files: Mapping[str, str],
    machine: Machine,
    *,
    reference: Mapping[str, float] | None = None,
    axis_names: Mapping[str, str] | None = None,
) -> Emulation:
    """Read ``files`` as the control of format ``fmt`` reads them.

    Parameters
    ----------
    fmt : {"linuxcnc", "siemens", "fanuc", "isg", "etalon"}
    files : mapping of file name to text
    machine : Machine
    reference : mapping of axis to float, optional
        Fanuc: machine coordinate of each axis's reference position (internal units).
    axis_names : mapping of machine axis to control axis name, optional
        Sinumerik machine-axis names; :func:`default_axis_names` when omitted.

    Returns
    -------
    Emulation
    """
    if fmt == "linuxcnc":
        tables = linuxcnc.load(files, joints(machine))
        return Emulation(tables, semantics=[_semantics("*.comp", linuxcnc.SEMANTICS)])
    if fmt == "siemens":
        names = dict(axis_names or default_axis_names(machine))
        tables = sinumerik.load(files, {v: k for k, v in names.items()})
        kinds = {"ENC_COMP": "$AA_ENC_COMP" in files.get("ENC_COMP.INI", "")}
        kinds["CEC"] = "$AN_CEC" in files.get("CEC.INI", "")
        semantics = [
            _semantics(f"{k}.INI", sinumerik.SEMANTICS[k]) for k, used in kinds.items() if used
        ]
        return Emulation(tables, semantics=semantics)
    if fmt == "fanuc":
        if reference is None:
            raise InputError("fanuc: the reference position of each axis is needed")
        tables = fanuc.load(files, reference)
        return Emulation(tables, semantics=[_semantics(fanuc.FILE, fanuc.SEMANTICS)])
    if fmt in ("isg", "etalon"):
        tables, constants, factors = isg.load(files, *chain(machine))
        return Emulation(tables, constants, factors, [_semantics("volcomp.lis", isg.SEMANTICS)])
    raise InputError(f"format: no emulation of {fmt!r}")
