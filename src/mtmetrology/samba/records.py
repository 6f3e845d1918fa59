"""SAMBA probing records: ball-centre indications, raw probed points, repeated campaigns.

Three CSV forms are read (ARCHITECTURE.md, "Files users bring and get"); lengths in mm,
rotary readings in degrees:

``ball,X,Y,Z,B,C[,S]``
    one ball-centre indication per row: the axis readings that put the stylus centre on
    the ball centre (Sepahi Boroujeni (2021) Ch. 5: the five-point estimate of the control).
``measurement,ball,X,Y,Z,B,C[,S,i,j,k]``
    raw probed points: every row is one trigger (stylus-centre readings), rows sharing a
    ``measurement`` id are one probing of one ball at one (B, C, S).  Each measurement is
    reduced to its centre by the least-squares sphere of known radius
    ``(ball diameter + stylus tip diameter)/2`` (the artefact file gives both) fitted in
    the linear readings (:func:`mtmetrology.fitting.fit_spheres`); ``i,j,k`` (approach
    direction) are informative only.
either form with a ``campaign`` column
    K repetitions of the same test (same balls and indexations in the same order).  The
    identification uses the mean indications; their sample covariance S (rank ≤ K − 1,
    so singular whenever K − 1 < 3n) is kept for the uncertainty: see
    :func:`mtmetrology.samba.uncertainty.indication_inputs` for how it is made usable.

An optional ``tool`` column names the stylus of each indication (a test with two stylus
lengths, Alami Mchichi (2018) Table 4.4); the artefact file's ``tools`` give their nominal
vectors.

Optional ``sense_<axis>`` columns (+1/−1) give the sense of motion of each axis (reversal
terms); without them the senses follow from the order of the rows
(:func:`mtmetrology.identification.senses_from_sequence`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mtmetrology.fitting import fit_spheres
from mtmetrology.fitting.least_squares import FitError
from mtmetrology.identification import senses_from_sequence
from mtmetrology.io.files import InputFileError
from mtmetrology.io.plausibility import check_scale
from mtmetrology.io.tables import Table, read_csv_table
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.readings_table import readings_from_table, senses_from_table
from mtmetrology.samba.artefact import SambaArtefact

__all__ = ["SambaRecords", "check_travel", "read_records"]

_AXES_OF_POSE = ("B", "C", "S")


@dataclass(frozen=True, eq=False)
class SambaRecords:
    """Ball-centre indications of one SAMBA test, in probing order.

    Attributes
    ----------
    source : str
        The file read.
    form : {"centres", "raw-points"}
        What the rows were.
    balls : tuple of str, length n
        Ball id of each indication.
    readings : (n, n_axes) ndarray
        Indications in internal units (mm, rad); the campaign mean for K campaigns.
    senses : (n, n_axes) ndarray or None
        Sense of motion of every axis (None when the model has no reversal terms).
    lines : (n,) ndarray of int
        File line of the first row of each indication.
    campaigns : (K, n, 3) ndarray or None
        Linear readings (mm) of each campaign, when the file had a ``campaign`` column.
    sphere_rms : (n_measurements,) ndarray or None
        RMS radial residual of each raw-point sphere fit, mm.
    tools : tuple of str or None
        Tool id of each indication (the ``tool`` column), None without one.
    """

    source: str
    form: str
    balls: tuple[str, ...]
    readings: np.ndarray = field(repr=False)
    senses: np.ndarray | None = field(repr=False)
    lines: np.ndarray = field(repr=False)
    campaigns: np.ndarray | None = field(default=None, repr=False)
    sphere_rms: np.ndarray | None = field(default=None, repr=False)
    tools: tuple[str, ...] | None = field(default=None, repr=False)

    @property
    def n_campaigns(self) -> int:
        return 1 if self.campaigns is None else self.campaigns.shape[0]

    def __len__(self) -> int:
        return len(self.balls)


def _where(table: Table, row: int) -> str:
    return f"{table.path}, line {table.lines[row]}"


def check_travel(machine: Machine, q: np.ndarray, where) -> None:
    """Refuse readings (k, n_axes) outside an axis travel; ``where(i)`` names row i."""
    for i, a in enumerate(machine.axis_names):
        travel = machine.axes[a].travel
        if travel is None:
            continue
        low, high = travel
        slack = 1e-9 * max(1.0, abs(low), abs(high))
        bad = np.flatnonzero((q[:, i] < low - slack) | (q[:, i] > high + slack))
        if bad.size:
            lim = machine.readings_to_customary(np.tile([[low], [high]], (1, machine.n_axes)))
            value = machine.readings_to_customary(q[bad[0]])[i]
            raise InputFileError(
                f"{where(bad[0])}: {a} = {value:.6g} lies outside the travel of "
                f"{machine.name} [{lim[0, i]:g}, {lim[1, i]:g}]; check the readings, the "
                "ball positions or the machine file"
            )


def _senses(machine: Machine, table: Table, readings: np.ndarray) -> np.ndarray | None:
    """Senses of motion: the ``sense_<axis>`` columns where given, else from the order
    of the rows; None when the model has no reversal terms."""
    if not any(p.kind == "reversal" for p in machine.parameters):
        return None
    out = senses_from_sequence(readings)
    given = senses_from_table(machine, table)
    if given is not None:
        columns = [k for k, a in enumerate(machine.axis_names) if table.has(f"sense_{a}")]
        out[:, columns] = given[:, columns]
    return out


def _groups(keys: list[str]) -> list[np.ndarray]:
    """Row indices of each distinct key, in order of first appearance."""
    order: dict[str, list[int]] = {}
    for i, key in enumerate(keys):
        order.setdefault(key, []).append(i)
    return [np.array(v) for v in order.values()]


def _reduce_raw_points(
    machine: Machine, table: Table, q: np.ndarray, balls: list[str], artefact: SambaArtefact
):
    """Centres of the raw-point measurements: (rows of first points, centre readings, rms)."""
    if artefact.stylus_tip_diameter_mm is None:
        raise InputFileError(
            f"{table.path}: raw probed points need the stylus tip diameter; add "
            "stylus_tip_diameter_mm to the artefact file"
        )
    diameters = {b.id: b.diameter_mm for b in artefact.balls}
    campaign = table.strings("campaign") if table.has("campaign") else [""] * len(table)
    keys = [f"{c}\x00{m}" for c, m in zip(campaign, table.strings("measurement"), strict=True)]
    linear = [i for i, a in enumerate(machine.axis_names) if a in machine.linear_axes]
    pose = [i for i, a in enumerate(machine.axis_names) if a in _AXES_OF_POSE]
    groups = _groups(keys)
    first = np.array([g[0] for g in groups])
    centres = np.empty((len(groups), machine.n_axes))
    rms = np.empty(len(groups))
    by_size: dict[tuple[int, str], list[int]] = {}
    for k, g in enumerate(groups):
        ball = balls[g[0]]
        other = next((i for i in g if balls[i] != ball), None)
        if other is not None:
            raise InputFileError(
                f"{_where(table, other)}: measurement {table.strings('measurement')[g[0]]!r} "
                f"mixes balls {ball!r} and {balls[other]!r}; one measurement probes one ball"
            )
        moved = [i for i in g if np.any(np.abs(q[i, pose] - q[g[0], pose]) > 1e-12)]
        if moved:
            raise InputFileError(
                f"{_where(table, moved[0])}: the rotary readings change within measurement "
                f"{table.strings('measurement')[g[0]]!r}; one measurement is one (B, C, S)"
            )
        if g.size < 4:
            raise InputFileError(
                f"{_where(table, g[0])}: measurement {table.strings('measurement')[g[0]]!r} "
                f"has {g.size} points; a ball centre needs at least 4 (5 is usual)"
            )
        by_size.setdefault((g.size, ball), []).append(k)
        centres[k] = q[g[0]]
    tip = artefact.stylus_tip_diameter_mm
    for (_, ball), members in by_size.items():
        radius = 0.5 * (diameters[ball] + tip)
        pts = np.stack([q[groups[k]][:, linear] for k in members])  # (k, size, 3)
        try:
            fit = fit_spheres(pts, radius=radius)
        except FitError as err:
            raise InputFileError(f"{table.path}: ball {ball}: {err}") from None
        bad = np.flatnonzero(~fit.success)
        if bad.size:
            raise InputFileError(
                f"{_where(table, groups[members[bad[0]]][0])}: the sphere fit of this "
                "measurement did not converge; check its points"
            )
        for j, k in enumerate(members):
            centres[k, linear] = fit.centres[j]
            rms[k] = fit.rms[j]
    return first, centres, rms


def read_records(path: str | Path, machine: Machine, artefact: SambaArtefact) -> SambaRecords:
    """Read SAMBA records in any of the three forms (see the module notes).

    Parameters
    ----------
    path : path-like
        The CSV file.
    machine : Machine
        The machine (its axes name the reading columns and bound the travels).
    artefact : SambaArtefact
        Ball ids, diameters, the scale bar and the stylus tip diameter.

    Returns
    -------
    SambaRecords

    Raises
    ------
    InputFileError
        A missing column, a NaN, a reading outside the travel, an unknown ball, a ball
        probed only once, a scale-bar ball never probed, campaigns that differ in their
        sequence, a raw measurement that mixes balls or has fewer than 4 points — each
        naming the file and line.
    """
    table = read_csv_table(path, required=["ball"])
    raw = table.has("measurement")
    q = readings_from_table(machine, table)
    balls = table.strings("ball")
    known = {b.id for b in artefact.balls}
    unknown = next((i for i, b in enumerate(balls) if b not in known), None)
    if unknown is not None:
        raise InputFileError(
            f"{_where(table, unknown)}: ball {balls[unknown]!r} is not in the artefact "
            f"(balls: {', '.join(sorted(known))})"
        )
    rows = np.arange(len(table))
    rms = None
    if raw:
        rows, q, rms = _reduce_raw_points(machine, table, q, balls, artefact)
        balls = [balls[i] for i in rows]
    campaign = None
    if table.has("campaign"):
        labels = table.strings("campaign")
        campaign = [labels[i] for i in rows]
    campaigns = None
    if campaign is not None:
        groups = _groups(campaign)
        first = groups[0]
        pose = [i for i, a in enumerate(machine.axis_names) if a in _AXES_OF_POSE]
        linear = [i for i, a in enumerate(machine.axis_names) if a in machine.linear_axes]
        if len(groups) < 2:
            raise InputFileError(f"{table.path}: a campaign column needs at least 2 campaigns")
        for g in groups[1:]:
            same = g.size == first.size and all(
                balls[i] == balls[j] for i, j in zip(g, first, strict=True)
            )
            if same:
                same = bool(np.allclose(q[g][:, pose], q[first][:, pose], rtol=0, atol=1e-9))
            if not same:
                raise InputFileError(
                    f"{_where(table, rows[g[0]])}: campaign {campaign[g[0]]!r} does not repeat "
                    f"the balls and indexations of campaign {campaign[first[0]]!r} in the same "
                    "order; every campaign must be the same test"
                )
        campaigns = np.stack([q[g][:, linear] for g in groups])  # (K, n, 3)
        mean = q[first].copy()
        mean[:, linear] = campaigns.mean(axis=0)
        q, balls, rows = mean, [balls[i] for i in first], rows[first]
    lines = table.lines[rows]
    _check_coverage(table.path, balls, lines, artefact)
    _check_scale_bar(machine, table.path, q, balls, artefact)
    sub = table.take(rows)
    senses = _senses(machine, sub, q)
    tools = None
    if table.has("tool"):
        tools = tuple(sub.strings("tool"))
        known_tools = {t.id for t in artefact.tools or []}
        bad = next((i for i, t in enumerate(tools) if t not in known_tools), None)
        if bad is not None:
            raise InputFileError(
                f"{table.path}, line {lines[bad]}: tool {tools[bad]!r} is not in the "
                f"artefact's tools ({', '.join(sorted(known_tools)) or 'none listed'})"
            )
    return SambaRecords(
        source=str(table.path),
        form="raw-points" if raw else "centres",
        balls=tuple(balls),
        readings=q,
        senses=senses,
        lines=lines,
        campaigns=campaigns,
        sphere_rms=rms,
        tools=tools,
    )


def _check_scale_bar(machine: Machine, path, q: np.ndarray, balls, artefact) -> None:
    """Refuse a scale-bar length the records cannot be of: the distance between the mean
    nominal stylus centres probed on its two end balls (within a ball's radius of the
    centres, so within a few mm of the bar's length) against the artefact's ``length_mm``
    (:func:`~mtmetrology.io.plausibility.check_scale`: a factor beyond √10 is a unit slip,
    not a machine's scale error)."""
    if artefact.scale_bar is None:
        return
    ends = artefact.scale_bar.ends
    ids = np.asarray(balls)
    if not all(np.any(ids == e) for e in ends):
        return  # _check_coverage names the missing end
    p = machine.forward(q)
    centres = [p[ids == e].mean(axis=0) for e in ends]
    check_scale(
        artefact.scale_bar.length_mm,
        float(np.linalg.norm(centres[1] - centres[0])),
        f"{path}: the artefact's scale_bar.length_mm ({ends[0]}-{ends[1]})",
    )


def _check_coverage(path: str, balls: list[str], lines, artefact: SambaArtefact) -> None:
    """Every master ball probed at least twice; both scale-bar balls probed (once is
    enough for them: the bar length ties their two centres, Alami Mchichi (2018) Table 4.1)."""
    counts: dict[str, int] = {}
    for b in balls:
        counts[b] = counts.get(b, 0) + 1
    bar = set(artefact.scale_bar.ends) if artefact.scale_bar is not None else set()
    for b, n in counts.items():
        if n < 2 and b not in bar:
            line = lines[balls.index(b)]
            raise InputFileError(
                f"{path}, line {line}: ball {b!r} is probed only once; its centre is then "
                "fitted exactly and adds nothing: probe it at two or more (B, C) indexations "
                "or remove it"
            )
    if artefact.scale_bar is not None:
        missing = [e for e in artefact.scale_bar.ends if e not in counts]
        if missing:
            raise InputFileError(
                f"{path}: scale-bar ball(s) {', '.join(missing)} never probed; probe both bar "
                "balls (at B = C = 0 and one more indexation), otherwise the scale gains are "
                "not identifiable"
            )
