"""SAMBA calibration planning: which balls, which (B, C) indexations (DETMAX).

Two DETMAX steps (Alami Mchichi 2018, §5.5, Fig. 5.3; digest 004 §3.9):

* **step 1** (:func:`choose_balls`): n master balls out of a candidate grid of pallet
  positions × stem lengths, every candidate probed at a fixed rich set of (B, C)
  indexations (450 in the source) wherever it is accessible;
* **step 2** (:func:`choose_indexations`): with the balls placed, M indexations out of the
  candidates, ``M = k × unknowns/3`` (:func:`~mtmetrology.design.counts.indexation_count`),
  every ball probed at every chosen indexation where it is accessible.

The rows of a design and its predictions are those of
:mod:`mtmetrology.design.programme`.

With several styli (``tools``) both steps plan the programme probed with every stylus:
step 1 scores each candidate ball with its rows probed by each stylus where every stylus
reaches it (the rows and accessibility of :mod:`~mtmetrology.design.programme`), so the
exchange maximises the criterion of the multi-stylus information matrix, and step 2
chooses indexations likewise.  The design also evaluates the same balls and indexations
with the first stylus alone (:attr:`SambaDesign.one_stylus`): the parameters only the
second stylus makes identifiable, and the condition number and predicted u before and
after (Alami Mchichi (2018) Table 4.4).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology.design.accessibility import AccessibilityRule
from mtmetrology.design.choices import SCALED_CRITERIA
from mtmetrology.design.counts import (
    MINUTES_PER_MEASUREMENT,
    count_rule_for,
    indexation_count,
)
from mtmetrology.design.criteria import (
    check_criterion,
    criterion_from_spectrum,
    scaled_spectrum,
)
from mtmetrology.design.detmax import BlockInformation, DetmaxResult, detmax
from mtmetrology.design.inputs import ScaleBarPlacement
from mtmetrology.design.programme import (
    ProgrammeRows,
    SambaProgramme,
    accessible_all,
    approach_senses,
    check_sigma,
    evaluate_programme,
    fixed_programme_rows,
    nominal_jacobian,
    per_tool,
    programme_problem,
)
from mtmetrology.display import NotebookRepr
from mtmetrology.errors import InputError, RankDeficientError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.rng import SeedLike, chunk_generators
from mtmetrology.units import from_internal

__all__ = [
    "BallInformation",
    "SambaDesign",
    "ball_information",
    "choose_balls",
    "choose_indexations",
    "plan_samba",
]


@dataclass
class _BallState:
    members: np.ndarray
    exchanges: int = 0


class BallInformation:
    """Step-1 candidates: master balls, each adding its own three centre unknowns.

    The information of a ball set ``S`` is assembled from per-candidate blocks of the
    Gram matrix: shared unknowns (machine parameters, tool, scale-bar balls) get
    ``F_0 + Σ_{c∈S} P_c``; each ball's centre couples only to the shared unknowns
    (``C_c``) and to itself (``O_c``). Trial designs are assembled and their spectra
    computed in one batched call (n ≤ a few balls: no rank-r update is needed).

    Parameters
    ----------
    fixed_info : ndarray, shape (s, s)
        Gram matrix of the rows every design has (shared unknowns).
    shared : ndarray, shape (N, s, s)
    cross : ndarray, shape (N, s, 3)
    own : ndarray, shape (N, 3, 3)
    criterion : str
    measurements_fixed : int
    measurements : ndarray of int, shape (N,)
    """

    def __init__(self, fixed_info, shared, cross, own, criterion, measurements_fixed, measurements):
        self.criterion = check_criterion(criterion)
        ref = np.sqrt(np.diag(fixed_info + shared.sum(axis=0)))
        ref = np.where(ref > 0, ref, 1.0)
        own_ref = np.sqrt(np.einsum("cii->ci", own))  # (N, 3)
        own_ref = np.where(own_ref > 0, own_ref, 1.0)
        self.fixed_info = fixed_info / ref[:, None] / ref[None, :]
        self.shared = shared / ref[None, :, None] / ref[None, None, :]
        self.cross = cross / ref[None, :, None] / own_ref[:, None, :]
        self.own = own / own_ref[:, :, None] / own_ref[:, None, :]
        self.measurements_fixed = int(measurements_fixed)
        self.measurements = np.asarray(measurements, dtype=int)

    @property
    def n_candidates(self) -> int:
        return self.shared.shape[0]

    def information(self, members) -> np.ndarray:
        """Gram matrix of a ball set (fixed reference scaling), shape (s + 3k, s + 3k)."""
        idx = np.flatnonzero(members) if np.asarray(members).dtype == bool else np.asarray(members)
        return self._assemble(idx[None, :])[0]

    def _assemble(self, sets: np.ndarray) -> np.ndarray:
        """Gram matrices of many ball sets at once, sets (t, k) -> (t, s + 3k, s + 3k)."""
        t, k = sets.shape
        s = self.fixed_info.shape[0]
        f = np.zeros((t, s + 3 * k, s + 3 * k))
        f[:, :s, :s] = self.fixed_info + self.shared[sets].sum(axis=1)
        for j in range(k):
            sl = slice(s + 3 * j, s + 3 * j + 3)
            f[:, :s, sl] = self.cross[sets[:, j]]
            f[:, sl, :s] = np.swapaxes(self.cross[sets[:, j]], 1, 2)
            f[:, sl, sl] = self.own[sets[:, j]]
        return f

    def _values(self, sets: np.ndarray, criterion: str | None = None) -> np.ndarray:
        criterion = self.criterion if criterion is None else criterion
        f = self._assemble(sets)
        lam = scaled_spectrum(f) if criterion in SCALED_CRITERIA else np.linalg.eigvalsh(f)
        m = self.measurements_fixed + self.measurements[sets].sum(axis=1)
        return criterion_from_spectrum(criterion, lam, m)

    def start(self, indices) -> _BallState:
        members = np.zeros(self.n_candidates, dtype=bool)
        members[np.asarray(indices, dtype=int)] = True
        return _BallState(members)

    def refresh(self, state) -> None:
        """Nothing is carried between iterations."""

    def value(self, state) -> float:
        return float(self._values(np.flatnonzero(state.members)[None, :])[0])

    def scores(self, state, sign, indices, criterion: str | None = None) -> np.ndarray:
        """Criterion of each trial ball set (adding or removing each candidate)."""
        base = np.flatnonzero(state.members)
        if sign > 0:
            sets = np.column_stack([np.broadcast_to(base, (len(indices), base.size)), indices])
        else:
            sets = np.array([base[base != i] for i in indices])
        return self._values(sets, criterion)

    def update(self, state, index, sign) -> None:
        state.members[index] = sign > 0


@dataclass(frozen=True)
class SambaDesign(NotebookRepr):
    """Result of a SAMBA design: the programme, the DETMAX runs and the counts.

    Shown in a notebook as the plan report (:mod:`mtmetrology.design.report`).

    Attributes
    ----------
    programme : SambaProgramme
    criterion : str
    k : float or None
    count_rule : str or None
        The reading of "k × unknowns/3" that ran: ``indexations`` or ``measurements``.
    balls_search : DetmaxResult or None
        Step 1 runs (None when the balls were given).
    indexations_search : DetmaxResult
        Step 2 runs.
    n_candidate_indexations : int
    n_accessible : int
        Candidate indexations at which at least one ball is accessible.
    count_rule_reason : str or None
        Why that reading (asked for, or the source's for the model).
    one_stylus : SambaProgramme or None
        With several styli: the same balls and indexations probed with the first stylus
        alone (what the others buy: :meth:`stylus_gain`).
    """

    programme: SambaProgramme
    criterion: str
    k: float | None
    count_rule: str | None
    balls_search: DetmaxResult | None
    indexations_search: DetmaxResult
    n_candidate_indexations: int
    n_accessible: int
    count_rule_reason: str | None = None
    one_stylus: SambaProgramme | None = None

    _renderer_module = "mtmetrology.design.report"

    def to_dict(
        self, minutes_per_measurement=MINUTES_PER_MEASUREMENT, minutes_per_indexation=0.0
    ) -> dict:
        p = self.programme
        rep = p.report

        def runs(res):
            if res is None:
                return None
            return {
                "criterion": res.criterion,
                "best_value": _num(res.best.value),
                "best_start_value": _num(res.best.start_value),
                "history": [_num(v) for v in res.best.history],
                "exchanges": res.best.exchanges,
                "stop": res.best.message,
                "start_values": [_num(r.start_value) for r in res.runs],
                "final_values": [_num(r.value) for r in res.runs],
            }

        header, rows = p.table()
        return {
            "kind": "samba-design",
            "version": 1,
            "machine": p.machine.name,
            "model": p.machine.model_name,
            "criterion": self.criterion,
            "k": self.k,
            "count_rule": self.count_rule,
            "count_rule_reason": self.count_rule_reason,
            "balls": [
                {"id": b, "centre_mm": c.tolist(), "stem_mm": float(c[2])}
                for b, c in zip(p.ball_ids, p.centres, strict=True)
            ],
            "scale_bar": {
                "ends": list(p.bar.ends),
                "centres_mm": [list(c) for c in p.bar.centres_mm],
                "length_mm": p.bar.length,
                "u_mm": p.bar.u_mm,
            },
            "indexations_deg": p.pairs_deg.tolist(),
            "n_indexations": len(p.pairs_deg),
            "n_candidate_indexations": self.n_candidate_indexations,
            "n_accessible_indexations": self.n_accessible,
            "n_measurements": p.n_measurements,
            "duration_h": p.duration_h(minutes_per_measurement, minutes_per_indexation),
            "minutes_per_measurement": minutes_per_measurement,
            "minutes_per_indexation": minutes_per_indexation,
            "probing_sigma_um": float(from_internal(p.sigma_mm, "µm")),
            "rank": rep.rank,
            "n_unknowns": rep.n_unknowns,
            "condition_scaled": _num(rep.condition_scaled),
            "condition_raw": _num(rep.condition_raw),
            "observability": rep.observability,
            "parameters": p.parameters(),
            "step1": runs(self.balls_search),
            "step2": runs(self.indexations_search),
            "tools": None
            if p.tools is None
            else [{"id": t, "vector_mm": v.tolist()} for t, v in p.tools],
            "stylus_gain": self.stylus_gain(),
            "programme": {"columns": header, "rows": rows},
        }

    def stylus_gain(self) -> dict | None:
        """What the second stylus buys, None with one stylus.

        Returns
        -------
        dict
            ``one_stylus`` and ``all_styli``: rank, unknowns, scaled condition number and
            the confounded groups of the machine parameters (``confounded``); ``resolved``:
            the parameters in a confounded group with one stylus and identifiable with all
            (the pairs of Alami Mchichi (2018) Table 4.4); ``parameters``: u of each with
            one stylus (None where not identifiable) and with all, customary units.
        """
        one = self.one_stylus
        if one is None:
            return None
        both = self.programme

        def diag(prog):
            rep = prog.report
            return {
                "rank": rep.rank,
                "n_unknowns": rep.n_unknowns,
                "condition_scaled": _num(rep.condition_scaled),
                "confounded": [list(g) for g in rep.confounded()],
            }

        before = diag(one)
        after = diag(both)
        params = set(self.programme.machine.parameter_names)
        lost = {n for g in before["confounded"] for n in g if n in params}
        still = {n for g in after["confounded"] for n in g}
        u_one = {q["name"]: q["u"] for q in one.parameters()}
        return {
            "one_stylus": before,
            "all_styli": after,
            "resolved": sorted(lost - still),
            "parameters": [
                {"name": q["name"], "unit": q["unit"], "u_one": u_one[q["name"]], "u_all": q["u"]}
                for q in both.parameters()
            ],
        }


def _num(x):
    return float(x) if np.isfinite(x) else None


def _check_machine(machine: Machine):
    if not {"B", "C"} <= set(machine.axis_names):
        raise InputError(f"machine {machine.name}: a SAMBA design needs rotary axes B and C")


def ball_information(
    machine: Machine,
    candidate_ids,
    candidate_centres: np.ndarray,
    indexations_deg: np.ndarray,
    *,
    criterion: str = "O2",
    bar: ScaleBarPlacement | None = None,
    rule: AccessibilityRule | None = None,
    sigma_mm: float = 0.001,
    tools=None,
) -> BallInformation:
    """The step-1 search space: each candidate ball's information at the rich set.

    Every candidate is probed at ``B = C = 0`` and at each indexation where accessible,
    with each stylus of ``tools`` in turn (the rows of
    :func:`~mtmetrology.design.programme.per_tool`), on top of the fixed rows (scale bar,
    spindle indexing) probed with each stylus. The Gram matrix of a ball set ``S`` is
    ``F(S) = J_0ᵀJ_0 + Σ_{c∈S} J_cᵀJ_c`` (rows weighted by 1/σ), assembled by
    :class:`BallInformation` from per-candidate blocks.

    Parameters
    ----------
    machine, candidate_ids, candidate_centres, indexations_deg, criterion, bar, rule, sigma_mm
        As in :func:`choose_balls`.
    tools : ndarray, shape (n_tools, 3), optional
        Vectors of several styli (mm), each with its own three tool unknowns; a candidate
        is probed at an indexation only where every stylus reaches it.

    Returns
    -------
    BallInformation

    Raises
    ------
    InputError
        No candidate accessible at any candidate indexation.
    """
    _check_machine(machine)
    check_sigma(sigma_mm)
    bar = bar or ScaleBarPlacement()
    rule = rule or AccessibilityRule()
    ids = [str(i) for i in candidate_ids]
    cent = np.asarray(candidate_centres, dtype=float)
    mask = accessible_all(machine, rule, cent, indexations_deg, tools, obstacles=False)
    if not mask.any():
        raise InputError(
            "no candidate ball is accessible at any candidate indexation: widen the travel, "
            "lower stem_cone_deg/clearance_mm in the accessibility rule, or move the grid"
        )
    n_tools = 0 if tools is None else len(tools)
    fixed_rows = per_tool(fixed_programme_rows(bar, []), n_tools)
    fixed_problem = programme_problem(
        machine,
        fixed_rows,
        dict(zip(bar.ends, bar.centres_mm, strict=True)),
        bar,
        sigma_mm,
        tools,
    )
    j0 = nominal_jacobian(fixed_problem)
    p = machine.n_params
    tool_names = [nm for nm in fixed_problem.names if nm.startswith("tool ")]
    shared_names = [*machine.parameter_names, *tool_names] + [
        f"ball {e} {c}" for e in bar.ends for c in "xyz"
    ]
    order0 = [fixed_problem.names.index(n) for n in shared_names]
    j0 = j0[:, order0]
    s = len(shared_names)
    q = p + len(tool_names)  # shared unknowns a candidate's rows see
    n = len(ids)
    shared = np.zeros((n, s, s))
    cross = np.zeros((n, s, 3))
    own = np.zeros((n, 3, 3))
    counts = np.zeros(n, dtype=int)
    pairs = np.asarray(indexations_deg, dtype=float)
    senses = approach_senses(len(pairs))
    for i in range(n):
        ok = np.flatnonzero(mask[:, i])
        rows = ProgrammeRows(
            [ids[i]] * (ok.size + 1),
            np.r_[0.0, pairs[ok, 0]],
            np.r_[0.0, pairs[ok, 1]],
            np.zeros(ok.size + 1),
            np.r_[1.0, senses[ok, 0]],
            np.r_[1.0, senses[ok, 1]],
        )
        rows = per_tool(rows, n_tools)
        prob = programme_problem(machine, rows, {ids[i]: cent[i]}, None, sigma_mm, tools)
        j = nominal_jacobian(prob)
        cols = [prob.names.index(nm) for nm in shared_names[:q]]
        own_cols = [prob.names.index(f"ball {ids[i]} {c}") for c in "xyz"]
        a = j[:, cols]
        b = j[:, own_cols]
        shared[i, :q, :q] = a.T @ a
        cross[i, :q] = a.T @ b
        own[i] = b.T @ b
        counts[i] = len(rows.balls)
    return BallInformation(j0.T @ j0, shared, cross, own, criterion, len(fixed_rows.balls), counts)


def choose_balls(
    machine: Machine,
    candidate_ids,
    candidate_centres: np.ndarray,
    n_balls: int,
    indexations_deg: np.ndarray,
    *,
    criterion: str = "O2",
    bar: ScaleBarPlacement | None = None,
    rule: AccessibilityRule | None = None,
    sigma_mm: float = 0.001,
    starts: int = 8,
    seed: SeedLike = None,
    executor=None,
    tools=None,
) -> tuple[list[str], np.ndarray, DetmaxResult]:
    """Step 1: the best ``n_balls`` of a candidate set for a fixed rich set of indexations.

    DETMAX exchanges candidates to maximise the criterion of ``F(S)``
    (:func:`ball_information`).

    Parameters
    ----------
    machine : Machine
        With rotary axes B, C and the error model to identify.
    candidate_ids : sequence of str, length N
    candidate_centres : ndarray, shape (N, 3)
        Ball centres in the workpiece frame, mm.
    n_balls : int
    indexations_deg : ndarray, shape (K, 2)
        (B, C) at which every candidate is probed where accessible (450 in seed 004).
    criterion : str
        D, A, E or O1–O5 (O2 in the source, Table 5.2).
    bar : ScaleBarPlacement, optional
    rule : AccessibilityRule, optional
        Rules 1–3 are applied to every candidate; rule 4 (other balls) to the chosen set
        in step 2, since which balls stand together is what step 1 decides.
    sigma_mm : float
        Standard uncertainty of one indication coordinate, mm.
    starts, seed, executor
        As in :func:`mtmetrology.design.detmax.detmax`.
    tools : ndarray, shape (n_tools, 3), optional
        Vectors of several styli (mm): every candidate is probed with each, so the balls
        chosen are the best for the multi-stylus programme (as in step 2).

    Returns
    -------
    ids : list of str
    centres : ndarray, shape (n_balls, 3)
    search : DetmaxResult

    References
    ----------
    Alami Mchichi, N. (2018), §5.5, Fig. 5.3 (DETMAX step 1); Mitchell (1974).

    Examples
    --------
    One ball of four candidates for the 13-parameter model. Within the preset's travel the
    tall stem at the pallet corner is reachable at the candidate indexations and its longer
    lever arms condition best; with a shorter Z travel it is not, and the short central stem
    wins, as in Alami Mchichi (2018), §5.7.1 (the choice depends on accessibility).

    >>> from mtmetrology.kinematics import Machine
    >>> from mtmetrology.design.inputs import grid_indexations
    >>> m = Machine.load("five-axis-wcbxfzyst", "13")
    >>> cands = np.array([[0, 40, 75], [0, 40, 175], [160, 120, 75], [160, 120, 175]])
    >>> pairs = grid_indexations(np.arange(-90, 91, 45), np.arange(0, 360, 60))
    >>> ids, _, res = choose_balls(m, list("abcd"), cands, 1, pairs, starts=1, seed=0)
    >>> ids
    ['d']
    """
    ids = [str(i) for i in candidate_ids]
    if not 1 <= n_balls <= len(ids):
        raise InputError(f"--n-balls {n_balls} must be between 1 and the {len(ids)} candidates")
    space = ball_information(
        machine,
        ids,
        candidate_centres,
        indexations_deg,
        criterion=criterion,
        bar=bar,
        rule=rule,
        sigma_mm=sigma_mm,
        tools=tools,
    )
    search = detmax(space, n_balls, starts=starts, seed=seed, executor=executor)
    chosen = search.best.members
    cent = np.asarray(candidate_centres, dtype=float)
    return [ids[i] for i in chosen], cent[chosen], search


def candidate_blocks(machine, ball_ids, centres, pairs, bar, rule, sigma_mm, tools=None):
    """Fixed rows, candidate blocks and accessibility of step 2 (``tools`` (n_tools, 3):
    every row probed with each stylus, a candidate's block holding all of them)."""
    mask = accessible_all(machine, rule, centres, pairs, tools)
    usable = np.flatnonzero(mask.any(axis=1))
    if usable.size == 0:
        raise InputError(
            "no candidate indexation has an accessible ball: widen the B/C candidates, "
            "move the balls or relax the accessibility rule (stem_cone_deg, clearance_mm, "
            "check_travel)"
        )
    senses = approach_senses(len(pairs))
    nb = len(ball_ids)
    n_tools = 0 if tools is None else len(tools)
    fixed = per_tool(fixed_programme_rows(bar, ball_ids), n_tools)
    cand_balls, cand_b, cand_c, cand_sb, cand_sc, owner = [], [], [], [], [], []
    for t in range(max(n_tools, 1)):
        for i in usable:
            for j in np.flatnonzero(mask[i]):
                cand_balls.append(ball_ids[j])
                cand_b.append(pairs[i, 0]), cand_c.append(pairs[i, 1])
                cand_sb.append(senses[i, 0]), cand_sc.append(senses[i, 1])
                owner.append((i, t * nb + j))
    cand = ProgrammeRows(
        cand_balls,
        np.array(cand_b),
        np.array(cand_c),
        np.zeros(len(cand_b)),
        np.array(cand_sb),
        np.array(cand_sc),
        None if tools is None else np.array([k // nb for _, k in owner]),
    )
    centre_of = dict(zip(ball_ids, centres, strict=True)) | dict(
        zip(bar.ends, bar.centres_mm, strict=True)
    )
    problem = programme_problem(
        machine, ProgrammeRows.concat([fixed, cand]), centre_of, bar, sigma_mm, tools
    )
    jac = nominal_jacobian(problem)
    nf = len(fixed.balls)
    fixed_rows = np.vstack([jac[: 3 * nf], jac[3 * (nf + len(cand.balls)) :]])  # + bar row
    blocks = np.zeros((len(pairs), 3 * nb * max(n_tools, 1), jac.shape[1]))
    counts = mask.sum(axis=1) * max(n_tools, 1)
    for k, (i, j) in enumerate(owner):
        blocks[i, 3 * j : 3 * j + 3] = jac[3 * (nf + k) : 3 * (nf + k) + 3]
    return fixed_rows, blocks, counts, mask, usable, len(fixed.balls)


def choose_indexations(
    machine: Machine,
    ball_ids,
    centres: np.ndarray,
    indexations_deg: np.ndarray,
    size: int,
    *,
    criterion: str = "D",
    bar: ScaleBarPlacement | None = None,
    rule: AccessibilityRule | None = None,
    sigma_mm: float = 0.001,
    starts: int = 8,
    seed: SeedLike = None,
    executor=None,
    tools=None,
) -> tuple[np.ndarray, np.ndarray, DetmaxResult]:
    """Step 2: the best ``size`` (B, C) indexations for balls in place.

    Parameters
    ----------
    machine : Machine
    ball_ids : sequence of str
    centres : ndarray, shape (n_balls, 3)
        Master-ball centres, workpiece frame, mm.
    indexations_deg : ndarray, shape (N, 2)
        Candidate (B, C), degrees; inaccessible balls are left out of each candidate and
        candidates with no accessible ball are never chosen.
    size : int
        Indexations in the design (see :func:`indexation_count`).
    criterion, bar, rule, sigma_mm, starts, seed, executor
        As in :func:`choose_balls` (all four accessibility rules apply here).
    tools : ndarray, shape (n_tools, 3), optional
        Vectors of several styli (mm): the programme is probed with each, a ball at an
        indexation only where every stylus reaches it.

    Returns
    -------
    pairs : ndarray, shape (size, 2)
        Chosen indexations in candidate order, degrees.
    senses : ndarray, shape (size, 2)
        Approach senses (±1) of B and C the design assumed at each.
    search : DetmaxResult

    Raises
    ------
    InputError
        No accessible candidate, or ``size`` larger than the accessible candidates.
    RankDeficientError
        If the best design found is rank deficient: name what to change (k, balls).

    Examples
    --------
    >>> from mtmetrology.kinematics import Machine
    >>> from mtmetrology.design.inputs import grid_indexations
    >>> m = Machine.load("five-axis-wcbxfzyst", "13")
    >>> pairs = grid_indexations(np.arange(-90, 91, 45), np.arange(0, 360, 60))
    >>> chosen, senses, res = choose_indexations(
    ...     m, ["1"], np.array([[80.0, 40.0, 75.0]]), pairs, 7, criterion="D", seed=0
    ... )
    >>> chosen.shape, bool(np.all(np.diff(res.best.history) >= 0))
    ((7, 2), True)
    """
    _check_machine(machine)
    check_sigma(sigma_mm)
    bar = bar or ScaleBarPlacement()
    rule = rule or AccessibilityRule()
    pairs = np.asarray(indexations_deg, dtype=float)
    c = np.asarray(centres, dtype=float)
    fixed_rows, blocks, counts, _, usable, n_fixed = candidate_blocks(
        machine, list(ball_ids), c, pairs, bar, rule, sigma_mm, tools
    )
    if size > usable.size:
        raise InputError(
            f"{size} indexations asked but only {usable.size} candidates have an accessible "
            "ball: lower --k or give more candidate indexations"
        )
    space = BlockInformation(fixed_rows, blocks[usable], criterion, n_fixed, counts[usable])
    search = detmax(space, size, starts=starts, seed=seed, executor=executor)
    chosen_rows = blocks[usable[search.best.members]].reshape(-1, blocks.shape[2])
    chosen = usable[search.best.members]
    if not _full_rank(np.vstack([fixed_rows, chosen_rows])):
        styli = None if tools is None else [(str(i), v) for i, v in enumerate(tools)]
        senses = approach_senses(len(pairs))[chosen]
        report = evaluate_programme(
            machine, ball_ids, c, pairs[chosen], bar=bar, rule=rule, sigma_mm=sigma_mm,
            senses=senses, tools=styli,
        ).report  # fmt: skip
        params = set(machine.parameter_names)
        groups = [g for g in report.confounded() if params & set(g)]
        listed = "; ".join(_short(g) for g in groups[:3]) or "set-up unknowns only"
        if len(groups) > 3:
            listed += f" and {len(groups) - 3} more combinations"
        raise RankDeficientError(
            f"the best {size}-indexation design found is rank deficient for the "
            f"{machine.n_params}-parameter model, confounding {listed}: raise --k, add balls "
            "or candidate indexations, add a second stylus (--tool) or use a smaller error "
            "model",
            confounded=tuple(tuple(g) for g in groups),
        )
    return pairs[chosen], approach_senses(len(pairs))[chosen], search


def _short(group, most: int = 4) -> str:
    """``A ~ B ~ C`` of a confounded group, the first ``most`` names and a count."""
    names = list(group)
    more = f" ~ … ({len(names)} unknowns)" if len(names) > most else ""
    return " ~ ".join(names[:most]) + more


def _full_rank(rows: np.ndarray, rtol: float = 1e-8) -> bool:
    """Rank test of the diagnostics: σ_min > rtol·σ_max of the unit-norm-column rows."""
    norms = np.linalg.norm(rows, axis=0)
    s = np.linalg.svd(rows / np.where(norms > 0, norms, 1.0), compute_uv=False)
    return bool(rows.shape[0] >= rows.shape[1] and s[-1] > rtol * s[0])


def plan_samba(
    machine: Machine,
    indexations_deg: np.ndarray,
    *,
    balls: tuple[list[str], np.ndarray] | None = None,
    candidates: tuple[list[str], np.ndarray] | None = None,
    n_balls: int | None = None,
    k: float = 3.0,
    count_rule: str = "source",
    criterion: str = "O2",
    bar: ScaleBarPlacement | None = None,
    rule: AccessibilityRule | None = None,
    sigma_mm: float = 0.001,
    starts: int = 8,
    seed: SeedLike = None,
    executor=None,
    tools=None,
) -> SambaDesign:
    """Plan a SAMBA test: step 1 (balls) when candidates are given, then step 2.

    Parameters
    ----------
    machine : Machine
        With the error model to identify.
    indexations_deg : ndarray, shape (N, 2)
        Candidate (B, C), degrees (also the fixed rich set of step 1).
    balls : (ids, centres), optional
        Balls already placed (skips step 1).
    candidates : (ids, centres), optional
        Candidate balls for step 1, with ``n_balls``.
    n_balls : int, optional
    k, count_rule
        Indexations ``M`` (:func:`indexation_count`); the default ``"source"`` reads
        "k × unknowns/3" as the source does for the model (:func:`count_rule_for`).
    criterion : str
        D, A, E or O1–O5, for both steps.
    bar, rule, sigma_mm, starts, seed, executor
        As in :func:`choose_indexations`; step 1 and step 2 draw independent streams
        from ``seed``.
    tools : sequence of (id, (3,) array_like), optional
        Two or more styli (ids and nominal vectors, mm; the first is the reference):
        the programme is probed with each, and the design reports what the others buy
        against the first alone (:meth:`SambaDesign.stylus_gain`).  Both steps use every
        stylus.

    Returns
    -------
    SambaDesign

    Raises
    ------
    InputError
        Both or neither of ``balls``/``candidates``, missing ``n_balls``, nothing
        accessible, an unknown criterion or count rule.
    RankDeficientError
        If the design cannot identify the model: raise k or add balls.

    Examples
    --------
    Strategy 1B.3n of seed 004 (13 parameters, one ball, k = 3): 21 indexations,
    29 measurements, about 0.66 h.

    >>> from mtmetrology.kinematics import Machine
    >>> from mtmetrology.design.inputs import grid_indexations
    >>> m = Machine.load("five-axis-wcbxfzyst", "13")
    >>> pairs = grid_indexations(np.arange(-90, 91, 30), np.arange(0, 360, 45))
    >>> d = plan_samba(m, pairs, balls=(["1"], [[80.0, 40.0, 75.0]]), k=3, starts=1, seed=0)
    >>> doc = d.to_dict()
    >>> doc["n_indexations"], doc["n_measurements"], round(doc["duration_h"], 2), doc["rank"]
    (21, 29, 0.66, 25)
    """
    criterion = check_criterion(criterion)
    if (balls is None) == (candidates is None):
        raise InputError(
            "give either the placed balls (--balls) or a candidate grid (--balls-from)"
        )
    bar = bar or ScaleBarPlacement()
    rule = rule or AccessibilityRule()
    vectors = None
    if tools is not None:
        tools = [(str(i), np.asarray(v, dtype=float)) for i, v in tools]
        if len(tools) < 2:
            raise InputError("--tool: give two or more styli, or none (the machine's tool)")
        vectors = np.array([v for _, v in tools])
    step_seeds = [np.random.SeedSequence(int(g.integers(2**63))) for g in chunk_generators(seed, 2)]
    balls_search = None
    if candidates is not None:
        if n_balls is None:
            raise InputError("--n-balls is required with a candidate grid (--balls-from)")
        ids, centres, balls_search = choose_balls(
            machine,
            candidates[0],
            candidates[1],
            n_balls,
            indexations_deg,
            criterion=criterion,
            bar=bar,
            rule=rule,
            sigma_mm=sigma_mm,
            starts=starts,
            seed=step_seeds[0],
            executor=executor,
            tools=vectors,
        )
    else:
        ids, centres = [str(b) for b in balls[0]], np.asarray(balls[1], dtype=float)
    count_rule, reason = count_rule_for(count_rule, machine.n_params)
    size = indexation_count(k, machine.n_params, len(ids), rule=count_rule)
    pairs, senses, search = choose_indexations(
        machine,
        ids,
        centres,
        indexations_deg,
        size,
        criterion=criterion,
        bar=bar,
        rule=rule,
        sigma_mm=sigma_mm,
        starts=starts,
        seed=step_seeds[1],
        executor=executor,
        tools=vectors,
    )
    common = {"bar": bar, "rule": rule, "sigma_mm": sigma_mm, "senses": senses}
    programme = evaluate_programme(machine, ids, centres, pairs, tools=tools, **common)
    one = None
    if tools is not None:
        one = evaluate_programme(machine, ids, centres, pairs, tools=tools[:1], **common)
    mask = accessible_all(machine, rule, centres, indexations_deg, vectors)
    return SambaDesign(
        programme=programme,
        criterion=criterion,
        k=float(k),
        count_rule=count_rule,
        balls_search=balls_search,
        indexations_search=search,
        n_candidate_indexations=len(indexations_deg),
        n_accessible=int(mask.any(axis=1).sum()),
        count_rule_reason=reason,
        one_stylus=one,
    )
