"""The SAMBA strategy comparison: balls × k × criterion, each strategy planned and checked.

Alami Mchichi (2018) builds Ch. 5 on a sweep of strategies (Tables 5.2, 5.3, 5.5): for
each number of balls, each multiple k of "unknowns/3" and each criterion, DETMAX trims
the candidate (B, C) indexations (step 2) and the strategy is judged by its condition
number (start → end of DETMAX, and Cond_N of all candidates), its predicted u and UPF
(eq. 6.14), its duration (eq. 5.14 and Table 5.5's rate) and an independent gauge-block
check (§6.5.3). The sweep is *nested* as in the source: the n-ball strategies use the
first n of the placed balls.

Gauge-block check (simulated)
-----------------------------
A machine with errors θ (given, or drawn uniformly within ±50 µm, µrad, µm/m with the
seed) probes the strategy's programme with Gaussian noise σ on each linear reading and
a bar length drawn within its u; the identification engine estimates θ̂. A gauge block of
length L at B = C = 0 is then probed at its two ends e_a, e_b: the readings are those of
the erroneous machine, ``q = q(e; θ)``, and the length the compensated machine indicates
is ``L̂ = ‖p(q_b; θ̂) − p(q_a; θ̂)‖``, so the length error is ``E = L̂ − L`` (θ̂ = 0: the
nominal, uncompensated model). The gauge is placed along X, along Y and along the XY
diagonal through the table centre; the check reports max |E| of each model.

References
----------
Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes : configuration
optimisée des artefacts et de la séquence de mesure de la méthode SAMBA*. PhD thesis,
Polytechnique Montréal, Tables 5.2, 5.3, 5.5, eq. 6.14, §6.5.3.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from mtmetrology.design.accessibility import AccessibilityRule, accessible
from mtmetrology.design.counts import MINUTES_PER_MEASUREMENT
from mtmetrology.design.criteria import check_criterion
from mtmetrology.design.inputs import ScaleBarPlacement
from mtmetrology.design.programme import SambaProgramme, approach_senses, evaluate_programme
from mtmetrology.design.samba import plan_samba
from mtmetrology.errors import InputError
from mtmetrology.identification import BallCentreProblem, ScaleBar, levenberg_marquardt
from mtmetrology.kinematics.machine import Machine
from mtmetrology.rng import SeedLike, chunk_generators
from mtmetrology.units import from_internal

__all__ = ["GAUGE_DIRECTIONS", "Strategy", "StrategyComparison", "compare_strategies"]

KIND = "samba-strategy-comparison"
#: Gauge-block directions of the simulated check (workpiece frame, B = C = 0).
GAUGE_DIRECTIONS = {"X": (1.0, 0.0, 0.0), "Y": (0.0, 1.0, 0.0), "XY": (0.7071, 0.7071, 0.0)}


@dataclass(frozen=True)
class Strategy:
    """One strategy of the sweep (``nB.kn`` of the source, with its criterion).

    Attributes
    ----------
    name : str
        ``"4B.2n O2"``: balls, k, criterion.
    n_balls, k, criterion
    n_indexations, n_measurements : int
    duration_h : float
        Eq. 5.14 count at Table 5.5's rate.
    condition_all : float
        Scaled condition number with every candidate indexation (the source's Cond_N).
    condition_start, condition_end : float
        Of the best DETMAX run's random start and of its result (Cond_n start / end).
    improvement : float
        ``(start − end)/start`` (the source's 55.7 % for 4B.2n, 84 parameters).
    parameters : list of dict
        Predicted ``u`` and ``upf`` per parameter (:meth:`SambaProgramme.parameters`).
    mean_upf : dict
        Mean UPF per parameter unit (a mean over mixed units is not comparable).
    gauge_nominal_um, gauge_calibrated_um : float
        max |E| of the simulated gauge-block check, nominal and compensated model, µm.
    """

    name: str
    n_balls: int
    k: float
    criterion: str
    n_indexations: int
    n_measurements: int
    duration_h: float
    condition_all: float
    condition_start: float
    condition_end: float
    improvement: float
    parameters: list
    mean_upf: dict
    gauge_nominal_um: float
    gauge_calibrated_um: float


@dataclass(frozen=True)
class StrategyComparison:
    """Result of :func:`compare_strategies`; ``to_dict``/``from_dict`` give its file form."""

    machine: str
    model: str
    strategies: tuple[Strategy, ...]
    sigma_um: float
    gauge_length_mm: float
    seed: int | None
    n_candidates: int

    def to_dict(self) -> dict:
        doc = {"kind": KIND, "version": 1, **asdict(self)}
        doc["strategies"] = [asdict(s) for s in self.strategies]
        return doc

    @classmethod
    def from_dict(cls, doc: dict) -> StrategyComparison:
        if doc.get("kind") != KIND or doc.get("version") != 1:
            raise InputError(f"not a {KIND} document of version 1: kind {doc.get('kind')!r}")
        fields = {k: v for k, v in doc.items() if k not in ("kind", "version")}
        fields["strategies"] = tuple(Strategy(**s) for s in doc["strategies"])
        return cls(**fields)

    def table(self) -> tuple[list[str], list[list]]:
        """Header and rows of the comparison table (customary units)."""
        header = [
            "strategy",
            "indexations",
            "measurements",
            "duration (h)",
            "Cond_N",
            "cond start",
            "cond end",
            "improvement (%)",
            "gauge |E| nominal (µm)",
            "gauge |E| calibrated (µm)",
        ]
        rows = [
            [
                s.name,
                s.n_indexations,
                s.n_measurements,
                f"{s.duration_h:.2f}",
                f"{s.condition_all:.4g}",
                f"{s.condition_start:.4g}",
                f"{s.condition_end:.4g}",
                f"{100 * s.improvement:.1f}",
                f"{s.gauge_nominal_um:.3g}",
                f"{s.gauge_calibrated_um:.3g}",
            ]
            for s in self.strategies
        ]
        return header, rows

    def figure(self):
        """Condition number (end) against duration, one marker per strategy."""
        from matplotlib.figure import Figure

        fig = Figure(figsize=(6.4, 3.8))
        ax = fig.add_subplot()
        for s in self.strategies:
            ax.plot(s.duration_h, s.condition_end, "o")
            ax.annotate(s.name, (s.duration_h, s.condition_end), fontsize=7)
        ax.set_xlabel("test duration (h)")
        ax.set_ylabel("condition number (columns scaled)")
        ax.set_title(f"SAMBA strategies, {self.model}-parameter model")
        return fig


def _start_condition(machine, ids, centres, pairs, start, bar, rule, sigma_mm) -> float:
    mask, _ = accessible(machine, rule, centres, pairs)
    usable = np.flatnonzero(mask.any(axis=1))
    chosen = usable[start]
    prog = evaluate_programme(
        machine,
        ids,
        centres,
        pairs[chosen],
        bar=bar,
        rule=rule,
        sigma_mm=sigma_mm,
        senses=approach_senses(len(pairs))[chosen],
    )
    return float(prog.report.condition_scaled)


def _identify(machine: Machine, prog: SambaProgramme, theta, rng) -> np.ndarray:
    """θ̂ of one simulated test of the programme (probing noise σ, bar length within u)."""
    r = prog.rows
    centre_of = dict(zip(prog.ball_ids, prog.centres, strict=True))
    centre_of |= dict(zip(prog.bar.ends, prog.bar.centres_mm, strict=True))
    senses = None
    if machine.chain.has_reversal:
        senses = np.ones((len(r.balls), machine.n_axes))
        senses[:, machine.axis_names.index("B")] = r.sense_b
        senses[:, machine.axis_names.index("C")] = r.sense_c
    targets = np.array([centre_of[b] for b in r.balls])
    q = machine.inverse(targets, prog.readings, theta, senses=senses)
    lin = [machine.axis_names.index(a) for a in machine.linear_axes]
    q[:, lin] += prog.sigma_mm * rng.standard_normal((len(q), len(lin)))
    bar = prog.bar
    length = bar.length + bar.u_mm * rng.standard_normal()
    problem = BallCentreProblem(
        machine,
        q,
        r.balls,
        senses=senses,
        scale_bars=[ScaleBar(tuple(bar.ends), length, bar.u_mm)],
        estimate_tool=True,
        sigma=prog.sigma_mm,
    )
    result = levenberg_marquardt(problem)
    return result.estimate[: machine.n_params]


def gauge_length_errors(machine: Machine, theta, theta_hat, length_mm: float, z_mm: float):
    """Length errors E = L̂ − L (mm) of a gauge of length L along each of
    :data:`GAUGE_DIRECTIONS` centred on the table axis at height z, B = C = 0: probed by the
    machine with errors θ, indicated by the model θ̂ (module notes)."""
    out = []
    q0 = np.zeros((2, machine.n_axes))
    senses = np.ones((2, machine.n_axes)) if machine.chain.has_reversal else None
    for d in GAUGE_DIRECTIONS.values():
        u = np.asarray(d) / np.linalg.norm(d)
        ends = np.array(
            [[0.0, 0.0, z_mm] - 0.5 * length_mm * u, [0.0, 0.0, z_mm] + 0.5 * length_mm * u]
        )
        q = machine.inverse(ends, q0, theta, senses=senses)
        p = machine.forward(q, theta_hat, senses=senses)
        out.append(np.linalg.norm(p[1] - p[0]) - length_mm)
    return np.array(out)


def compare_strategies(
    machine: Machine,
    indexations_deg: np.ndarray,
    balls: tuple[list[str], np.ndarray],
    *,
    n_balls=(1, 2, 3, 4),
    ks=(2.0, 3.0),
    criteria=("O2",),
    count_rule: str = "source",
    bar: ScaleBarPlacement | None = None,
    rule: AccessibilityRule | None = None,
    sigma_mm: float = 0.001,
    truth: np.ndarray | None = None,
    gauge_length_mm: float = 300.0,
    gauge_z_mm: float = 100.0,
    starts: int = 3,
    seed: SeedLike = None,
    progress=None,
) -> StrategyComparison:
    """Plan and check every strategy of a balls × k × criterion sweep.

    Parameters
    ----------
    machine : Machine
        With the error model to identify.
    indexations_deg : ndarray, shape (N, 2)
        Candidate (B, C), degrees.
    balls : (ids, centres)
        Placed balls; the n-ball strategies use the first n (nested tests).
    n_balls, ks, criteria : sequences
        The sweep (criteria: D, A, E, O1–O5).
    count_rule, bar, rule, sigma_mm, starts
        As in :func:`~mtmetrology.design.samba.plan_samba`.
    truth : ndarray, optional
        The simulated machine's errors θ (internal units); by default uniform within
        ±50 µm, µrad, µm/m drawn from the seed.
    gauge_length_mm, gauge_z_mm : float
        Gauge block of the simulated check (the source's is 500 mm; it must fit the travels).
    seed : int, optional
        Every random start, truth and simulated test derives from it.
    progress : callable, optional
        ``progress(done, total)`` after each strategy, for a progress display.

    Returns
    -------
    StrategyComparison

    Raises
    ------
    InputError
        A ball count larger than the balls given or below 1, k ≤ 0, an unknown criterion.
    RankDeficientError
        A strategy of the sweep that cannot identify the model (raise k or add balls).
    """
    ids, centres = [str(b) for b in balls[0]], np.asarray(balls[1], dtype=float)
    pairs = np.asarray(indexations_deg, dtype=float)
    criteria = [check_criterion(c) for c in criteria]
    for n in n_balls:
        if not 1 <= n <= len(ids):
            raise InputError(f"--n-balls {n}: between 1 and the {len(ids)} balls given")
    for k in ks:
        if not k > 0:
            raise InputError(f"--k {k}: must be positive")
    bar = bar or ScaleBarPlacement()
    rule = rule or AccessibilityRule()
    combos = [(n, k, c) for n in n_balls for k in ks for c in criteria]
    gens = chunk_generators(seed, len(combos) + 1)
    if truth is None:
        truth = 50.0 * gens[-1].uniform(-1, 1, machine.n_params) * machine.parameter_scales
    strategies = []
    cond_all: dict[int, float] = {}
    for (n, k, crit), g in zip(combos, gens, strict=False):
        sub = (ids[:n], centres[:n])
        if n not in cond_all:
            full = evaluate_programme(machine, *sub, pairs, bar=bar, rule=rule, sigma_mm=sigma_mm)
            cond_all[n] = float(full.report.condition_scaled)
        design = plan_samba(
            machine,
            pairs,
            balls=sub,
            k=k,
            count_rule=count_rule,
            criterion=crit,
            bar=bar,
            rule=rule,
            sigma_mm=sigma_mm,
            starts=starts,
            seed=int(g.integers(2**63)),
        )
        prog = design.programme
        start = _start_condition(
            machine, *sub, pairs, design.indexations_search.best.start, bar, rule, sigma_mm
        )
        end = float(prog.report.condition_scaled)
        theta_hat = _identify(machine, prog, truth, g)
        gauge_nom = gauge_length_errors(
            machine, truth, np.zeros_like(truth), gauge_length_mm, gauge_z_mm
        )
        gauge_cal = gauge_length_errors(machine, truth, theta_hat, gauge_length_mm, gauge_z_mm)
        params = prog.parameters()
        by_unit: dict[str, list[float]] = {}
        for p in params:
            by_unit.setdefault(p["upf_unit"], []).append(p["upf"])
        strategies.append(
            Strategy(
                name=f"{n}B.{k:g}n {crit}",
                n_balls=n,
                k=float(k),
                criterion=crit,
                n_indexations=len(prog.pairs_deg),
                n_measurements=prog.n_measurements,
                duration_h=float(prog.duration_h(MINUTES_PER_MEASUREMENT)),
                condition_all=cond_all[n],
                condition_start=start,
                condition_end=end,
                improvement=(start - end) / start,
                parameters=params,
                mean_upf={u: float(np.mean(v)) for u, v in by_unit.items()},
                gauge_nominal_um=float(from_internal(np.abs(gauge_nom).max(), "µm")),
                gauge_calibrated_um=float(from_internal(np.abs(gauge_cal).max(), "µm")),
            )
        )
        if progress is not None:
            progress(len(strategies), len(combos))
    return StrategyComparison(
        machine=machine.name,
        model=machine.model_name,
        strategies=tuple(strategies),
        sigma_um=float(from_internal(sigma_mm, "µm")),
        gauge_length_mm=float(gauge_length_mm),
        seed=seed if isinstance(seed, int) else None,
        n_candidates=len(pairs),
    )
