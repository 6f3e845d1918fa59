"""Verification of compensation tables on the machine: a check programme and the template
of the readings taken there, with the predicted residual at each check point.

A table with the wrong sign doubles the machine's error instead of removing it, and no
computation on our side can show it: only the machine can.  The procedure:

1. ``mtm export FORMAT … --verify-program`` writes, beside the tables, a short NC programme
   for the target control and ``verify_readings.csv``.  The programme moves along each
   checked linear axis to a handful of check positions, first in the positive direction,
   then (after an overrun) in the negative one, the other axes at a middle position
   approached in the positive direction, with a dwell (``G04``) at each check position where
   a reading is taken.  The template lists the points in programme order with their axis
   readings (mm, degrees), the sense of travel of every axis, the predicted residual
   ``r`` after compensation with its expanded uncertainty ``U`` (k = 2) and the
   uncompensated error ``e`` there (µm, :func:`export_compensation` ``at_points``).
2. With the tables loaded, the user runs the programme and enters the measured deviation
   of position (ISO 230-2: the actual position reached minus the target position, of the
   tool relative to the workpiece, µm) in ``mx_um``, ``my_um``, ``mz_um``.  A laser
   interferometer aligned with the axis of the line (beam through the tool point, so that
   no Abbe offset enters) measures the component along that axis only: ``mx_um`` on the X
   line.  A probe on an artefact may give all three.
3. ``mtm export check verify_readings.csv`` compares them
   (:mod:`mtmetrology.export.verification_check`).

References
----------
ISO 230-2:2014, *Determination of accuracy and repeatability of positioning of numerically
controlled axes* (deviation of position, target positions approached in both directions).
LinuxCNC G-code reference (``docs/src/gcode/g-code.adoc``): ``G4 P`` dwell in seconds,
comments in parentheses.  Beckhoff TF5200 (ISG kernel) programming manual, "Dwell time
(G04), (#TIME)": ``G04 X`` in seconds, alone in its block.  SINUMERIK programming manual
Fundamentals, "Dwell time (G4)": ``G4 F`` in seconds, in its own block; comments after
``;``.  FANUC operator's manuals, "Dwell (G04)": ``X`` in seconds with a decimal point.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from datetime import UTC, datetime
from typing import NamedTuple

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.export.workflow import ExportResult, export_compensation
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.topology import LINEAR_AXES

__all__ = [
    "DIALECTS",
    "TEMPLATE",
    "CheckPlan",
    "export_with_verification",
    "plan_checks",
    "programme",
    "template",
]

TEMPLATE = "verify_readings.csv"
_COMPONENTS = "xyz"


class Dialect(NamedTuple):
    """How a control's NC language writes the few words of the check programme."""

    control: str
    file: str
    comment: str  # format of a comment line: "({})" or "; {}"
    metric: str  # block selecting mm input
    dwell: str  # dwell block, {} the seconds
    start: tuple[str, ...] = ()
    end: tuple[str, ...] = ("M30",)
    upper: bool = False  # comments in capitals (older FANUC character sets)


DIALECTS = {
    "linuxcnc": Dialect("LinuxCNC", "verify.ngc", "({})", "G21 G90 G94", "G4 P{:.1f}"),
    "fanuc": Dialect(
        "FANUC",
        "O1029.nc",
        "({})",
        "G21 G90 G94",
        "G04 X{:.1f}",
        start=("%", "O1029 (MTM VERIFY)"),
        end=("M30", "%"),
        upper=True,
    ),
    "siemens": Dialect("SINUMERIK", "MTM_VERIFY.MPF", "; {}", "G71 G90 G94", "G4 F{:.1f}"),
    "isg": Dialect("ISG kernel", "verify.nc", "({})", "G71 G90 G94", "G04 X{:.1f}"),
    "etalon": Dialect("ISG kernel", "verify.nc", "({})", "G71 G90 G94", "G04 X{:.1f}"),
    # A volumetric grid goes to no one control: the ISO 6983 words common to them.
    "grid": Dialect("ISO 6983 (generic)", "verify.nc", "({})", "G21 G90 G94", "G04 X{:.1f}"),
}


@dataclass(frozen=True)
class CheckPlan:
    """Check points of the verification programme, in programme order.

    Attributes
    ----------
    machine : str
    axis_names : tuple of str
        The machine's axes, the columns of ``readings`` and ``senses``.
    axes : tuple of str
        The checked (linear) axes, one line each.
    points : tuple of str
        Point ids, ``X03+``: axis, position index from 1, sense of travel.
    line : tuple of str
        The axis moved to reach each point.
    readings : ndarray, shape (n, n_axes)
        Axis readings, customary units (mm, degrees).
    senses : ndarray, shape (n, n_axes)
        Sense of travel (+1 / −1) of every axis at each point.
    overrun_mm : float
        Travel beyond the first and last positions before the approach.
    """

    machine: str
    axis_names: tuple
    axes: tuple
    points: tuple
    line: tuple
    readings: np.ndarray
    senses: np.ndarray
    overrun_mm: float


def _travel(machine: Machine, axis: str) -> tuple[float, float]:
    t = machine.axes[axis].travel
    if t is None:
        raise InputError(f"--verify-program: axis {axis} of {machine.name} has no travel")
    scale = 1.0 if axis in LINEAR_AXES else math.pi / 180
    return t[0] / scale, t[1] / scale


def _middle(machine: Machine, axis: str) -> float:
    """Where an axis waits while another is checked: the middle of a linear travel; 0° on
    a rotary axis that reaches it (its reference), else the middle of its travel."""
    if axis == "S" or machine.axes[axis].travel is None:
        return 0.0
    low, high = _travel(machine, axis)
    if axis not in LINEAR_AXES and low <= 0.0 <= high:
        return 0.0
    return 0.5 * (low + high)


def plan_checks(
    machine: Machine,
    axes: Sequence[str] | None = None,
    positions: int = 5,
    overrun_mm: float = 5.0,
) -> CheckPlan:
    """The check points: ``positions`` equally spaced positions on each checked axis,
    from ``low + overrun`` to ``high − overrun``, approached in the positive then in the
    negative direction; the other axes at :func:`_middle`, approached positively.

    Parameters
    ----------
    machine : Machine
    axes : sequence of str, optional
        Axes to check; every linear axis of the machine when omitted.  A rotary axis is
        refused: a tool-point reading does not isolate its angular positioning error.
    positions : int
        Check positions per axis (≥ 2).
    overrun_mm : float
        Overrun before each approach (> 0), so that the sense of travel is known.

    Returns
    -------
    CheckPlan

    Raises
    ------
    InputError
        A rotary or unknown axis, fewer than 2 positions, an overrun the travel cannot hold.
    """
    if positions < 2:
        raise InputError(f"--verify-positions: {positions} < 2")
    if not overrun_mm > 0:
        raise InputError(f"--verify-overrun: {overrun_mm:g} mm must be > 0")
    checked = tuple(axes) if axes else machine.linear_axes
    for a in checked:
        if a not in machine.axis_names:
            raise InputError(f"--axes: {a} is not an axis of {machine.name}")
        if a not in LINEAR_AXES:
            raise InputError(
                f"--verify-program: {a} is a rotary axis; the programme checks linear axes "
                "(a tool-point reading does not isolate an angular positioning error)"
            )
    names = machine.axis_names
    middle = np.array([_middle(machine, a) for a in names])
    ids, lines, rows, senses = [], [], [], []
    for a in checked:
        low, high = _travel(machine, a)
        if high - low <= 2 * overrun_mm:
            raise InputError(
                f"--verify-overrun: {overrun_mm:g} mm twice exceeds the travel of {a} "
                f"[{low:g}, {high:g}] mm"
            )
        k = names.index(a)
        p = np.linspace(low + overrun_mm, high - overrun_mm, positions)
        for sense, order in ((1, range(positions)), (-1, reversed(range(positions)))):
            for i in order:
                row = middle.copy()
                row[k] = p[i]
                s = np.ones(len(names))
                s[k] = sense
                ids.append(f"{a}{i + 1:02d}{'+' if sense > 0 else '-'}")
                lines.append(a)
                rows.append(row)
                senses.append(s)
    for k, a in enumerate(names):  # the waiting axes are approached from below
        if a != "S" and a not in checked and machine.axes[a].travel is not None:
            if middle[k] - overrun_mm < _travel(machine, a)[0]:
                raise InputError(
                    f"--verify-overrun: {a} cannot wait at {middle[k]:g} after an overrun of "
                    f"{overrun_mm:g} (travel starts at {_travel(machine, a)[0]:g})"
                )
    return CheckPlan(
        machine.name,
        names,
        checked,
        tuple(ids),
        tuple(lines),
        np.array(rows),
        np.array(senses),
        float(overrun_mm),
    )


def _words(names: Sequence[str], values: Sequence[float]) -> str:
    # A decimal point always: FANUC reads "X100" as 100 least increments (0.1 mm).
    return " ".join(f"{a}{v:.3f}" for a, v in zip(names, values, strict=True))


def programme(
    plan: CheckPlan,
    fmt: str,
    files: Sequence[str] = (),
    *,
    feed: float = 1000.0,
    dwell_s: float = 4.0,
) -> tuple[str, str]:
    """The NC programme of the check, in the dialect of ``fmt`` (:data:`DIALECTS`).

    Straight ``G01`` moves at ``feed`` (mm/min) in absolute machine-axis positions (the
    readings of the template), a dwell of ``dwell_s`` seconds at each check point, named in
    the comment before it.

    Parameters
    ----------
    plan : CheckPlan
    fmt : str
        The export format: its control's dialect.
    files : sequence of str
        The table files, named in the header.
    feed : float
        Feed rate, mm/min.
    dwell_s : float
        Dwell at each check point, s.

    Returns
    -------
    (str, str)
        File name and text.
    """
    d = DIALECTS[fmt]
    lines = list(d.start)

    def comment(text: str) -> None:
        lines.append(d.comment.format(text.upper() if d.upper else text))

    comment(f"mtm export {fmt}: check of the compensation tables on {plan.machine}")
    if files:
        comment(f"tables: {', '.join(files)}; load them before running")
    comment("positions are machine axis positions in mm: run with no work offset")
    comment("and no tool length or radius compensation active; moves are straight G01")
    comment("from where the machine stands: start clear of the workpiece")
    comment(f"at each dwell of {dwell_s:g} s read the deviation of the point named before it")
    comment(f"and enter it in {TEMPLATE} in um: actual minus target position")
    lines.append(d.metric)
    # The spindle is not moved: its reading is 0 in the template.
    cols = [k for k, a in enumerate(plan.axis_names) if a != "S"]
    words = [plan.axis_names[k] for k in cols]
    current = None
    for i, pid in enumerate(plan.points):
        a = plan.line[i]
        k = words.index(a)
        row = plan.readings[i, cols]
        if a != current:  # a new line: the waiting axes approach their middle from below
            current = a
            others = [j for j, w in enumerate(words) if w != a]
            comment(f"line {a}: " + ", ".join(f"{words[j]} {row[j]:.3f}" for j in others))
            if others:
                names = [words[j] for j in others]
                lines.append(f"G01 {_words(names, row[others] - plan.overrun_mm)} F{feed:g}")
                lines.append(f"G01 {_words(names, row[others])}")
            lines.append(f"G01 {a}{row[k] - plan.overrun_mm:.3f} F{feed:g}")
        elif plan.senses[i, cols[k]] != plan.senses[i - 1, cols[k]]:  # the turn: overrun
            lines.append(f"G01 {a}{plan.readings[i - 1, cols[k]] + plan.overrun_mm:.3f}")
        lines.append(f"G01 {a}{row[k]:.3f}")
        sense = "+" if plan.senses[i, cols[k]] > 0 else "-"
        comment(f"read {pid}: {a} {row[k]:.3f} travel {sense}")
        lines.append(d.dwell.format(dwell_s))
    lines.extend(d.end)
    return d.file, "\n".join(lines) + "\n"


def template(
    plan: CheckPlan, at_points: dict, fmt: str, files: Sequence[str] = (), when: str = ""
) -> str:
    """``verify_readings.csv``: one row per check point, in programme order.

    Columns: ``point``, ``axis`` (the axis of the line), the readings (mm, degrees; the
    spindle omitted), ``sense_<axis>`` (+1 / −1), the predicted residual ``rx_um ry_um
    rz_um``, its ``Ux_um Uy_um Uz_um`` (k = 2; empty without a covariance), the
    uncompensated error ``ex_um ey_um ez_um``, then the empty columns the user fills:
    ``mx_um my_um mz_um`` (measured deviation, actual − target) and ``u_reading_um`` (the
    standard uncertainty of a reading, µm; or ``mtm export check --u-reading``).

    Parameters
    ----------
    plan : CheckPlan
    at_points : dict
        ``r``, ``U`` (or None), ``e``: arrays (n, 3) in µm at the plan's points, as
        :func:`export_compensation` returns them.
    fmt : str
    files : sequence of str
        The table files, named in the header.
    when : str
        Time stamp of the header.

    Returns
    -------
    str
        The CSV text.
    """
    cols = [k for k, a in enumerate(plan.axis_names) if a != "S"]
    names = [plan.axis_names[k] for k in cols]
    out = io.StringIO()
    out.write(
        f"# mtm export {fmt}: readings of the compensation check on {plan.machine}"
        + (f", written {when}" if when else "")
        + "\n"
        + (f"# tables: {' '.join(files)}\n" if files else "")
        + "# positions mm (deg); r: predicted residual after compensation, U its expanded "
        "uncertainty (k = 2), e: uncompensated error, all um, tool relative to workpiece\n"
        "# fill mx_um/my_um/mz_um with the measured deviation (actual - target, um); a laser "
        "along the line's axis gives the component of that axis only (mx_um on line X)\n"
        "# fill u_reading_um (standard uncertainty of a reading, um) or give --u-reading; "
        "then: mtm export check verify_readings.csv\n"
    )
    w = csv.writer(out, lineterminator="\n")
    w.writerow(
        ["point", "axis", *names, *(f"sense_{a}" for a in names)]
        + [f"{q}{c}_um" for q in "rUe" for c in _COMPONENTS]
        + [f"m{c}_um" for c in _COMPONENTS]
        + ["u_reading_um"]
    )
    r, big_u, e = at_points["r"], at_points["U"], at_points["e"]
    for i, pid in enumerate(plan.points):
        u_cells = [""] * 3 if big_u is None else [f"{v:.4f}" for v in big_u[i]]
        w.writerow(
            [pid, plan.line[i]]
            + [f"{plan.readings[i, k]:.3f}" for k in cols]
            + [f"{plan.senses[i, k]:+.0f}" for k in cols]
            + [f"{v:.4f}" for v in r[i]]
            + u_cells
            + [f"{v:.4f}" for v in e[i]]
            + ["", "", "", ""]
        )
    return out.getvalue()


def _split(at_points: dict, n: int) -> tuple[dict, dict]:
    """The first ``n`` rows of every array of ``at_points``, and the rest."""

    def part(sl):
        return {k: None if v is None else v[sl] for k, v in at_points.items()}

    return part(slice(0, n)), part(slice(n, None))


def export_with_verification(
    machine: Machine,
    parameters,
    fmt: str,
    *,
    verify_positions: int | None = None,
    verify_overrun_mm: float = 5.0,
    at: np.ndarray | None = None,
    at_senses: np.ndarray | None = None,
    axes: Sequence[str] | None = None,
    when: str | None = None,
    **options,
) -> tuple[ExportResult, dict]:
    """:func:`export_compensation`, and with ``verify_positions`` the check programme and
    the readings template at the check points of :func:`plan_checks`.

    The predictions at the check points come from the same call as the tables (its
    ``at_points``); the user's ``at`` readings keep their place in the result.

    Parameters
    ----------
    machine, parameters, fmt, options
        As :func:`export_compensation` (``axes`` too).
    verify_positions : int, optional
        Check positions per axis; no verification files when None.
    verify_overrun_mm : float
        Overrun before each approach, mm.
    at, at_senses : ndarray, optional
        The user's readings (internal units) and senses of travel, as
        :func:`export_compensation`.
    when : str, optional
        Time stamp written in the template's header (UTC now when omitted).

    Returns
    -------
    result : ExportResult
    files : dict of str to str
        The programme (:data:`DIALECTS` file name) and :data:`TEMPLATE`; empty without
        ``verify_positions``.

    Raises
    ------
    InputError
        As :func:`export_compensation` and :func:`plan_checks`; no linear axis to check.
    """
    if verify_positions is None:
        result = export_compensation(
            machine, parameters, fmt, at=at, at_senses=at_senses, axes=axes, **options
        )
        return result, {}
    checked = [a for a in axes if a in LINEAR_AXES] if axes else None
    if axes and not checked:
        raise InputError(f"--verify-program: no linear axis among --axes {','.join(axes)}")
    plan = plan_checks(machine, checked, verify_positions, verify_overrun_mm)
    q = machine.readings_from_customary(plan.readings)
    n_user = 0 if at is None else len(at)
    user_senses = np.ones_like(at) if at is not None and at_senses is None else at_senses
    all_q = q if at is None else np.vstack([at, q])
    all_s = plan.senses if at is None else np.vstack([user_senses, plan.senses])
    result = export_compensation(
        machine, parameters, fmt, at=all_q, at_senses=all_s, axes=axes, **options
    )
    mine, checks = _split(result.at_points, n_user)
    if at is None:
        mine = None
    elif at_senses is None:
        mine["senses"] = None
    result = replace(result, at_points=mine)
    tables = sorted(result.files)
    name, text = programme(plan, fmt, tables)
    stamp = when or datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    return result, {name: text, TEMPLATE: template(plan, checks, fmt, tables, stamp)}
