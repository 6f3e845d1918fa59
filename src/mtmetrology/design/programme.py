"""A SAMBA probing programme: its rows, its identification problem and its predictions.

Every programme contains the rows of seed 004 eq. 5.14: each master ball at B = C = 0
(m_0°), the scale bar at (0°, 0°) and (0°, 90°), and the first scale-bar ball at spindle
indexations S = 90°, 180°, 270° (tool/spindle separation), then every master ball at
each chosen indexation where it is accessible. The rows are those of the identification
engine (:class:`~mtmetrology.identification.BallCentreProblem`, weighted by the probing
noise σ and the bar's u, evaluated at the nominal point), so the condition number and
the uncertainties a programme predicts are what ``mtm machine identifiability`` and a
calibration of the simulated programme give.

Models with reversal terms (E_BBb, E_CCb) need both senses of approach: each candidate
indexation carries a sense of approach of B and of C, alternating over the candidate
list so that the four combinations are equally represented, and the programme states
them in ``sense_B, sense_C`` columns (the indexation is approached from that side).

Several styli (Alami Mchichi (2018) Table 4.4: a second stylus length separates E_AY1 from
E_YY1, and the like): the whole programme, fixed rows included, is probed with each
stylus in turn (each stylus needs its own spindle indexing and scale-bar probings to
have its own three tool unknowns), a ball at an indexation only where every stylus
reaches it, and the programme states the stylus of each row in a ``tool`` column.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from mtmetrology.design.accessibility import AccessibilityRule, accessible
from mtmetrology.design.counts import MINUTES_PER_MEASUREMENT, estimate_test_duration_h
from mtmetrology.design.criteria import uncertainty_propagation_factors
from mtmetrology.design.inputs import ScaleBarPlacement
from mtmetrology.errors import InputError
from mtmetrology.identification import (
    BallCentreProblem,
    IdentifiabilityReport,
    ScaleBar,
    analyse_identifiability,
)
from mtmetrology.kinematics.machine import Machine
from mtmetrology.units import from_internal

__all__ = [
    "ProgrammeRows",
    "SambaProgramme",
    "approach_senses",
    "check_sigma",
    "evaluate_programme",
    "fixed_programme_rows",
    "nominal_jacobian",
    "order_indexations",
    "programme_problem",
]

SPINDLE_DEG = (90.0, 180.0, 270.0)
BAR_PAIRS_DEG = ((0.0, 0.0), (0.0, 90.0))


def approach_senses(n: int) -> np.ndarray:
    """(B, C) senses of candidate i: the four combinations in turn, (n, 2) of ±1."""
    i = np.arange(n)
    return np.column_stack(
        [np.where(i % 2 == 0, 1.0, -1.0), np.where((i // 2) % 2 == 0, 1.0, -1.0)]
    )


@dataclass(frozen=True)
class ProgrammeRows:
    """Indications of a (partial) programme: ball id, B, C, S (degrees), senses and the
    stylus of each (index into the programme's tools; None: the machine's one tool)."""

    balls: list
    b: np.ndarray
    c: np.ndarray
    s: np.ndarray
    sense_b: np.ndarray
    sense_c: np.ndarray
    tool: np.ndarray | None = None

    @staticmethod
    def concat(parts):
        tool = None
        if any(p.tool is not None for p in parts):
            tool = np.concatenate(
                [p.tool if p.tool is not None else np.zeros(len(p.balls), int) for p in parts]
            )
        return ProgrammeRows(
            [b for p in parts for b in p.balls],
            *(
                np.concatenate([getattr(p, f) for p in parts])
                for f in ("b", "c", "s", "sense_b", "sense_c")
            ),
            tool,
        )

    def with_tool(self, index: int) -> ProgrammeRows:
        """The same rows probed with stylus ``index``."""
        return replace(self, tool=np.full(len(self.balls), int(index)))


def per_tool(rows: ProgrammeRows, n_tools: int) -> ProgrammeRows:
    """The rows probed with each of ``n_tools`` styli in turn (unchanged for 0: the
    machine's one tool, no tool column)."""
    if n_tools == 0:
        return rows
    return ProgrammeRows.concat([rows.with_tool(t) for t in range(n_tools)])


def accessible_all(machine, rule, centres, pairs, tools=None, **kw) -> np.ndarray:
    """Accessibility mask (N, n_balls) for every stylus at once: a ball is probed at an
    indexation only where each stylus reaches it."""
    if tools is None:
        return accessible(machine, rule, centres, pairs, **kw)[0]
    masks = [accessible(machine.with_tool(t), rule, centres, pairs, **kw)[0] for t in tools]
    return np.logical_and.reduce(masks)


def fixed_programme_rows(bar: ScaleBarPlacement, ball_ids) -> ProgrammeRows:
    balls, b, c, s = [], [], [], []
    for bid in ball_ids:  # m_0°: every master ball at B = C = 0
        balls.append(bid), b.append(0.0), c.append(0.0), s.append(0.0)
    for bb, cc in BAR_PAIRS_DEG:
        for end in bar.ends:
            balls.append(end), b.append(bb), c.append(cc), s.append(0.0)
    for ss in SPINDLE_DEG:  # tool/spindle separation on the first bar ball
        balls.append(bar.ends[0]), b.append(0.0), c.append(0.0), s.append(ss)
    n = len(balls)
    return ProgrammeRows(balls, np.array(b), np.array(c), np.array(s), np.ones(n), np.ones(n))


def programme_problem(
    machine, rows: ProgrammeRows, centres: dict, bar: ScaleBarPlacement | None, sigma, tools=None
):
    """The identification problem of a programme (readings by inverse kinematics);
    ``tools`` (n_tools, 3), mm, the styli ``rows.tool`` indexes (each with its own
    three tool unknowns)."""
    cols = {a: np.zeros(len(rows.balls)) for a in machine.axis_names}
    cols["B"], cols["C"] = rows.b, rows.c
    if "S" in cols:
        cols["S"] = rows.s
    guess = machine.readings_from_customary(cols)
    targets = np.array([centres[b] for b in rows.balls], dtype=float)
    multi = {}
    if tools is not None:
        multi = {"tools": np.asarray(tools, dtype=float), "tool_index": rows.tool}
    tool = None if tools is None else multi["tools"][rows.tool]
    q = machine.inverse(targets, guess, tool=tool)
    senses = None
    if machine.chain.has_reversal:
        senses = np.ones((len(rows.balls), machine.n_axes))
        senses[:, machine.axis_names.index("B")] = rows.sense_b
        senses[:, machine.axis_names.index("C")] = rows.sense_c
    bars = [ScaleBar(tuple(bar.ends), bar.length, bar.u_mm)] if bar is not None else []
    return BallCentreProblem(
        machine,
        q,
        rows.balls,
        senses=senses,
        scale_bars=bars,
        estimate_tool=True,
        sigma=sigma,
        **multi,
    )


def nominal_jacobian(problem: BallCentreProblem) -> np.ndarray:
    return problem.evaluate(problem.initial())[1]


@dataclass(frozen=True)
class SambaProgramme:
    """An ordered SAMBA probing programme and what it predicts.

    Attributes
    ----------
    machine : Machine
    ball_ids : tuple of str
        Master balls.
    centres : ndarray, shape (n_balls, 3)
        Their centres in the workpiece frame, mm.
    bar : ScaleBarPlacement
    pairs_deg : ndarray, shape (M, 2)
        Chosen (B, C) indexations in probing order, degrees.
    rows : ProgrammeRows
        Every indication in order (ball, B, C, S, senses).
    readings : ndarray, shape (M_T, n_axes)
        Nominal readings, internal units.
    report : IdentifiabilityReport
        Rank, condition numbers and O1–O5 of the programme's Jacobian.
    standard_uncertainty : ndarray or None, shape (n_params,)
        Predicted standard uncertainty of each machine parameter for the probing noise
        ``sigma_mm`` (internal units); None when rank deficient.
    sigma_mm : float
    tools : tuple of (id, (3,) ndarray) or None
        The styli of a programme with several (ids and nominal vectors, mm).
    """

    machine: Machine
    ball_ids: tuple
    centres: np.ndarray
    bar: ScaleBarPlacement
    pairs_deg: np.ndarray
    rows: ProgrammeRows = field(repr=False)
    readings: np.ndarray = field(repr=False)
    report: IdentifiabilityReport = field(repr=False)
    standard_uncertainty: np.ndarray | None
    sigma_mm: float
    tools: tuple | None = None

    @property
    def n_measurements(self) -> int:
        return len(self.rows.balls)

    def duration_h(
        self, minutes_per_measurement=MINUTES_PER_MEASUREMENT, minutes_per_indexation=0.0
    ):
        return estimate_test_duration_h(
            self.n_measurements,
            len(self.pairs_deg),
            minutes_per_measurement=minutes_per_measurement,
            minutes_per_indexation=minutes_per_indexation,
        )

    def table(self) -> tuple[list[str], list[list]]:
        """Header and rows of the programme CSV: ``ball,B,C,S,X,Y,Z`` (+ senses).

        X, Y, Z are the nominal readings that put the stylus centre on the ball centre
        (mm), so the file is also a ball-centre indication file of the nominal machine.
        """
        m = self.machine
        cust = m.readings_to_customary(self.readings)
        lin = {a: cust[:, m.axis_names.index(a)] for a in ("X", "Y", "Z")}
        header = ["ball", "B", "C", "S", "X", "Y", "Z"]
        reversal = m.chain.has_reversal
        if reversal:
            header += ["sense_B", "sense_C"]
        if self.tools is not None:
            header.append("tool")
        out = []
        r = self.rows
        for i, bid in enumerate(r.balls):
            row = [bid, f"{r.b[i]:.6g}", f"{r.c[i]:.6g}", f"{r.s[i]:.6g}"]
            row += [f"{lin[a][i]:.6f}" for a in ("X", "Y", "Z")]
            if reversal:
                row += [f"{int(r.sense_b[i]):+d}", f"{int(r.sense_c[i]):+d}"]
            if self.tools is not None:
                row.append(self.tools[int(r.tool[i])][0])
            out.append(row)
        return header, out

    def parameters(self) -> list[dict]:
        """Machine parameters with their predicted u in customary units, and the UPF.

        ``upf`` is u divided by the probing σ in µm (Alami Mchichi 2018, eq. 6.14; exact
        when the scale bar's u is proportional to σ, as with the default 1 µm each), in
        the parameter's unit per µm: compare it only between designs of the same parameter
        list and units (see :func:`~mtmetrology.design.criteria.
        uncertainty_propagation_factors`).
        """
        m = self.machine
        sigma_um = float(from_internal(self.sigma_mm, "µm"))
        out = []
        for i, (name, unit) in enumerate(zip(m.parameter_names, m.parameter_units, strict=True)):
            u = upf = None
            if self.standard_uncertainty is not None:
                u = float(from_internal(self.standard_uncertainty[i], unit))
                upf = u / sigma_um
            out.append({"name": name, "unit": unit, "u": u, "upf": upf, "upf_unit": f"{unit}/µm"})
        return out


def check_sigma(sigma_mm):
    """Refuse a probing σ that is not a positive number (mm)."""
    if not (sigma_mm > 0 and np.isfinite(sigma_mm)):
        raise InputError(f"probing sigma must be a positive number, got {sigma_mm} mm")


def order_indexations(pairs_deg: np.ndarray) -> np.ndarray:
    """Probing order: B ascending, C serpentine (ascending, then descending on the next B).

    Short rotary moves; the approach sense of each indexation is stated separately.
    """
    p = np.asarray(pairs_deg, dtype=float)
    out = []
    for k, b in enumerate(np.unique(p[:, 0])):
        row = p[p[:, 0] == b]
        row = row[np.argsort(row[:, 1])]
        out.append(row if k % 2 == 0 else row[::-1])
    return np.vstack(out) if out else p.reshape(0, 2)


def evaluate_programme(
    machine: Machine,
    ball_ids,
    centres: np.ndarray,
    pairs_deg: np.ndarray,
    *,
    bar: ScaleBarPlacement | None = None,
    rule: AccessibilityRule | None = None,
    sigma_mm: float = 0.001,
    senses: np.ndarray | None = None,
    order: bool = True,
    tools=None,
) -> SambaProgramme:
    """The programme of balls × indexations, with its diagnostics and predicted u.

    Parameters
    ----------
    machine : Machine
    ball_ids : sequence of str
    centres : ndarray, shape (n_balls, 3)
    pairs_deg : ndarray, shape (M, 2)
        Indexations, degrees; each ball is probed at each where accessible.
    bar, rule, sigma_mm
        As in :func:`choose_indexations`.
    senses : ndarray, shape (M, 2), optional
        Approach senses (±1) of B and C per indexation (as returned by
        :func:`choose_indexations`); alternating combinations by default.
    order : bool
        Put the indexations in probing order (:func:`order_indexations`).
    tools : sequence of (id, (3,) array_like), optional
        Several styli: ids and nominal vectors (mm); the programme is probed with each
        in turn (module notes).

    Returns
    -------
    SambaProgramme

    Examples
    --------
    The linear pairing c = 3b of the old strategy (Alami Mchichi 2018, Table 4.1) with
    the 84-coefficient model: E_ZC/E_ZB and E_CB/E_CC are confounded.

    >>> from mtmetrology.kinematics import Machine
    >>> m = Machine.load("five-axis-wcbxfzyst", "84")
    >>> balls = np.array([[-80, -40, 100], [80, -40, 150], [80, 120, 75], [-80, 120, 175]])
    >>> line = np.array([(b, 3 * b) for b in range(-90, 91, 15)], dtype=float)
    >>> free = AccessibilityRule(check_travel=False)
    >>> p = evaluate_programme(m, list("1234"), balls, line, rule=free)
    >>> p.report.full_rank, p.n_measurements   # 11 fixed + 13 x 4
    (False, 63)
    """
    check_sigma(sigma_mm)
    bar = bar or ScaleBarPlacement()
    rule = rule or AccessibilityRule()
    ids = [str(b) for b in ball_ids]
    c = np.asarray(centres, dtype=float)
    pairs = np.asarray(pairs_deg, dtype=float).reshape(-1, 2)
    senses = approach_senses(len(pairs)) if senses is None else np.asarray(senses, dtype=float)
    if order:
        ordered = order_indexations(pairs)
        idx = [int(np.flatnonzero(np.all(pairs == row, axis=1))[0]) for row in ordered]
        pairs, senses = pairs[idx], senses[idx]
    vectors = None if tools is None else np.array([t[1] for t in tools], dtype=float)
    mask = (
        accessible_all(machine, rule, c, pairs, vectors)
        if len(pairs)
        else np.zeros((0, len(ids)), bool)
    )
    parts = [fixed_programme_rows(bar, ids)]
    for i in range(len(pairs)):
        js = np.flatnonzero(mask[i])
        parts.append(
            ProgrammeRows(
                [ids[j] for j in js],
                np.full(js.size, pairs[i, 0]),
                np.full(js.size, pairs[i, 1]),
                np.zeros(js.size),
                np.full(js.size, senses[i, 0]),
                np.full(js.size, senses[i, 1]),
            )
        )
    rows = per_tool(ProgrammeRows.concat(parts), 0 if tools is None else len(tools))
    centre_of = dict(zip(ids, c, strict=True)) | dict(zip(bar.ends, bar.centres_mm, strict=True))
    problem = programme_problem(machine, rows, centre_of, bar, sigma_mm, vectors)
    jac = nominal_jacobian(problem)
    report = analyse_identifiability(
        jac, problem.names, n_measurements=len(rows.balls), report_names=machine.parameter_names
    )
    u = None
    if report.full_rank:
        u = uncertainty_propagation_factors(jac)[: machine.n_params]
    return SambaProgramme(
        machine=machine,
        ball_ids=tuple(ids),
        centres=c,
        bar=bar,
        pairs_deg=pairs,
        rows=rows,
        readings=problem.readings,
        report=report,
        standard_uncertainty=u,
        sigma_mm=sigma_mm,
        tools=None if tools is None else tuple((str(i), np.asarray(v, float)) for i, v in tools),
    )
