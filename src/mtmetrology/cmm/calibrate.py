"""Kinematic calibration of a bridge CMM from ball-plate records, with U1/U2/U3.

:func:`calibrate_ballplate` builds the candidate model (:mod:`mtmetrology.cmm.models`),
fixes its datum by rank, and solves the ball-plate problem
(:class:`~mtmetrology.cmm.problem.BallPlateProblem`) with the identification engine
(:func:`mtmetrology.identification.levenberg_marquardt`).  A set-up that cannot see some errors
(a plate only ever horizontal cannot see the errors that need a Z lever) is refused with a
:class:`~mtmetrology.errors.RankDeficientError` naming the unobservable combinations.

Uncertainties (Salacheep 2016, §4.5.3, Tables 4.1–4.3, as U1/U2/U3) are propagated from the
*full* covariance ``(JᵀJ)⁻¹`` of the weighted problem, never from a truncated SVD: the
source's fixed rank K = 36 drops the weakly determined directions and so hides exactly the
uncertainty a poor set-up has (digest of Salacheep 2016, §2.12, T16).

- U1: mean standard uncertainty of the estimated ball centres (plate frame), per axis;
- U2: mean standard uncertainty of the predicted CMM error at random points in the
  measured region (the bounding box of the indications), per axis;
- U3: the same over the whole working volume (the axis travels).

When the residuals contradict the model or σ (chi-squared p < 0.01) the covariance, hence
U1–U3, is scaled by the variance factor s² (the identification engine's adequacy rule,
:mod:`mtmetrology.identification.adequacy`; ``adequacy="a-priori"`` keeps it).

Examples
--------
A virtual CMM with a 20 µrad squareness error (X to Y), a 3 x 3 plate in three positions
probed with three styli:

>>> import numpy as np
>>> from mtmetrology.kinematics import Machine
>>> from mtmetrology.cmm import BallPlate, PositionSet, ProbeSet, simulate_ballplate
>>> cmm = Machine.load("cmm-moving-bridge")
>>> plate = BallPlate(kind="ball-plate", u_mm=0.0005, balls=[
...     {"id": f"{i}{j}", "x_mm": 250.0 * i, "y_mm": 250.0 * j}
...     for i in range(3) for j in range(3)])
>>> probes = ProbeSet(kind="probe-set", probes=[
...     {"id": "A", "offset_mm": [0, 0, -150]}, {"id": "B", "offset_mm": [60, 60, -150]},
...     {"id": "C", "offset_mm": [-60, 60, -100]}])
>>> styli = ["A", "B", "C"]
>>> positions = PositionSet(kind="ballplate-positions", positions=[
...     {"id": "H", "origin_mm": [300, 200, 150], "probes": styli},
...     {"id": "V", "origin_mm": [300, 500, 10], "rotation_deg": [90, 0, 0], "probes": styli},
...     {"id": "W", "origin_mm": [650, 200, 10], "rotation_deg": [90, 0, 90], "probes": styli}])
>>> from mtmetrology.units import from_internal, to_internal
>>> theta = np.zeros(cmm.n_params)
>>> theta[cmm.parameter_names.index("E_C0X")] = to_internal(20.0, "µrad")
>>> sim = simulate_ballplate(cmm, theta, plate, positions, probes, sigma=0.0005, seed=1)
>>> cal = calibrate_ballplate(cmm, sim.records, plate, probes, model="seed", sigma=0.0005)
>>> i = cal.machine.parameter_names.index("E_C0X")
>>> value, u = cal.theta[i], cal.parameters.standard_uncertainty[i]
>>> [round(float(from_internal(v, "µrad")), 1) for v in (value, u)]
[19.4, 1.3]

References
----------
Salacheep, P. (2016). *Error Compensation and Uncertainty Evaluation of CMMs Based on
Kinematic Error Models and Gaussian Processes*. MPhil thesis, Brunel University London,
§4.5 and Tables 4.1–4.3.
JCGM 100:2008, §5.2 (law of propagation of uncertainty).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from threadpoolctl import threadpool_limits

from mtmetrology.cmm.files import BallPlate, BallPlateRecords, ProbeSet
from mtmetrology.cmm.models import (
    Datum,
    ModelChoice,
    choose_datum,
    machine_for_model,
    parse_model,
)
from mtmetrology.cmm.notebook import CMMNotebookRepr
from mtmetrology.cmm.problem import BallPlateProblem
from mtmetrology.errors import RankDeficientError
from mtmetrology.identification.adequacy import residual_patterns
from mtmetrology.identification.diagnostics import analyse_identifiability
from mtmetrology.identification.solver import IdentificationResult, levenberg_marquardt
from mtmetrology.kinematics.compensation import compensation_covariance
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.rng import as_generator
from mtmetrology.units import from_internal

__all__ = [
    "BallPlateCalibration",
    "calibrate_ballplate",
    "check_design",
    "cross_validate",
    "error_covariance",
    "model_machine",
]

KIND = "ballplate-calibration"
#: Datum per (machine definition, model, basis): it depends on nothing else (fixed design).
_DATUMS: dict = {}


def model_machine(base: Machine, model: ModelChoice | str, basis: str | None = None, prefer=()):
    """The machine with the kept terms of a model, and the datum that chose them."""
    choice = parse_model(model) if isinstance(model, str) else model
    candidates = machine_for_model(base, choice, basis)
    key = (candidates.spec.model_dump_json(), choice.name, basis, tuple(prefer))
    datum = _DATUMS.get(key)
    if datum is None:
        datum = _DATUMS[key] = choose_datum(candidates, prefer=prefer)
    if choice.is_seed and not datum.dropped:
        return candidates, datum
    machine = candidates.with_parameters(datum.kept)
    return machine, datum


def error_covariance(machine: Machine, theta, covariance, readings, tools) -> np.ndarray:
    """Covariance (n, 3, 3) of the predicted stylus-centre position (= of the error).

    ``V_e = J_θ V_θ J_θᵀ`` with ``J_θ = ∂p/∂θ`` of the kinematic engine (JCGM 100, 5.2):
    the covariance of a coordinate compensated with the estimate θ
    (:func:`mtmetrology.kinematics.compensation.compensation_covariance`).
    """
    return compensation_covariance(machine, readings, theta, covariance, tool=tools)[1]


@dataclass(frozen=True, eq=False)
class BallPlateCalibration(CMMNotebookRepr):
    """Result of :func:`calibrate_ballplate`.

    Attributes
    ----------
    machine : Machine
        The CMM with the identified parameters active.
    parameters : ParameterSet
        Values and covariance of the error parameters (internal units).
    identification : IdentificationResult
        The full solve: every unknown (poses, balls), covariance, residuals, diagnostics.
    problem : BallPlateProblem
    datum : Datum
    model : str
    summary : dict
        U1, U2, U3 per axis (µm) and the regions used.
    """

    machine: Machine
    parameters: ParameterSet
    identification: IdentificationResult
    problem: BallPlateProblem
    datum: Datum
    model: str
    summary: dict

    @property
    def theta(self) -> np.ndarray:
        return self.parameters.values

    def compensate(self, readings, tools) -> np.ndarray:
        """Compensated stylus-centre coordinates (n, 3), mm."""
        return self.machine.forward(readings, self.theta, tool=tools)

    def residual_patterns(self) -> dict:
        """RMS of the indication residuals by plate position and by stylus, per axis (µm)
        (:func:`~mtmetrology.identification.adequacy.residual_patterns`)."""
        prob, res = self.problem, self.identification
        n = len(prob.readings)
        weighted = res.residuals[: 3 * n].reshape(n, 3)
        rec = prob.records
        return residual_patterns(
            weighted * prob.sigma,
            {"position": rec.positions, "probe": rec.probes},
            weighted=weighted,
        )

    def to_document(self, model_selection: dict | None = None) -> dict:
        """The result JSON: a parameter set (``kind: ballplate-calibration``) and more."""
        from scipy import stats  # here, not at the top: importing it takes 0.5 s

        doc = self.parameters.to_document()
        doc["kind"] = KIND
        res = self.identification
        x, u = res.estimate, res.standard_uncertainty
        prob = self.problem
        poses = []
        for k, pid in enumerate(prob.position_ids):
            i = prob.n_params + 6 * k
            poses.append(
                {
                    "position": pid,
                    "rotation_urad": from_internal(x[i : i + 3], "µrad").tolist(),
                    "translation_mm": x[i + 3 : i + 6].tolist(),
                    "u_rotation_urad": from_internal(u[i : i + 3], "µrad").tolist(),
                    "u_translation_um": from_internal(u[i + 3 : i + 6], "µm").tolist(),
                }
            )
        s = prob.ball_slice
        balls = [
            {
                "id": b,
                "xyz_mm": x[s][3 * k : 3 * k + 3].tolist(),
                "u_um": from_internal(u[s][3 * k : 3 * k + 3], "µm").tolist(),
            }
            for k, b in enumerate(prob.ball_ids)
        ]
        doc["fit"] = {
            "model": self.model,
            "status": res.status,
            "iterations": res.nit,
            "sigma_um": from_internal(prob.sigma, "µm"),
            "variance_factor": res.variance_factor,
            # χ² test of ‖r‖² against its dof: a small p says the model (or σ) does not explain
            # the residuals and the covariance, hence U1–U3, is optimistic
            "chi2_p_value": float(stats.chi2.sf(2.0 * res.cost, res.dof)) if res.dof > 0 else None,
            "rms_residual_um": from_internal(
                prob.sigma * float(np.sqrt(np.mean(res.residuals[: 3 * len(prob.readings)] ** 2))),
                "µm",
            ),
            "n_indications": len(prob.readings),
            "positions": list(prob.position_ids),
            "rank": res.diagnostics.rank,
            "n_unknowns": len(res.names),
            "condition_scaled": res.diagnostics.condition_scaled,
        }
        doc["datum"] = self.datum.to_dict()
        doc["poses"] = poses
        doc["balls"] = balls
        doc["uncertainty"] = self.summary
        if res.adequacy is not None:
            doc["adequacy"] = res.adequacy.to_dict()
        # the residual RMS by plate position and by stylus: where the model misses
        doc["residual_patterns"] = self.residual_patterns()
        if model_selection is not None:
            doc["model_selection"] = model_selection
        return doc


def _summary(machine, theta, cov_theta, res, problem, probes, rng) -> dict:
    """U1, U2, U3 per axis (µm) from the full covariance (module notes)."""
    cov = res.covariance
    s = problem.ball_slice
    u_balls = np.sqrt(np.diag(cov)[s]).reshape(-1, 3)
    lo_meas, hi_meas = problem.readings.min(axis=0), problem.readings.max(axis=0)
    travel = np.array([machine.axes[a].travel for a in machine.axis_names])
    tool = problem.tools[0]

    def mean_u(lo, hi):
        q = lo + (hi - lo) * rng.random((200, 3))
        v = error_covariance(machine, theta, cov_theta, q, tool)
        return from_internal(np.sqrt(np.diagonal(v, axis1=1, axis2=2)).mean(axis=0), "µm")

    return {
        "method": "full covariance (J^T J)^-1 of the weighted problem, no truncation",
        "rank": int(res.diagnostics.rank),
        "U1_um": from_internal(u_balls.mean(axis=0), "µm").tolist(),
        "U2_um": mean_u(lo_meas, hi_meas).tolist(),
        "U3_um": mean_u(travel[:, 0], travel[:, 1]).tolist(),
        "region_mm": [lo_meas.tolist(), hi_meas.tolist()],
        "volume_mm": travel.T.tolist(),
        "probe_offset_mm": tool.tolist(),
        "n_points": 200,
    }


def calibrate_ballplate(
    base: Machine,
    records: BallPlateRecords,
    plate: BallPlate,
    probes: ProbeSet,
    *,
    model: ModelChoice | str = "seed",
    sigma: float,
    basis: str | None = None,
    prefer=(),
    seed=0,
    adequacy: str = "scale",
) -> BallPlateCalibration:
    """Identify the CMM's error parameters, plate poses and ball centres.

    Parameters
    ----------
    base : Machine
        The CMM definition (e.g. preset ``cmm-moving-bridge``).
    records : BallPlateRecords
        Validated indications (see :func:`mtmetrology.cmm.files.read_records`).
    plate : BallPlate
    probes : ProbeSet
    model : str or ModelChoice
        ``seed`` or ``full-<d>`` (:func:`mtmetrology.cmm.models.parse_model`).
    sigma : float
        Standard uncertainty of one indication coordinate, mm.
    basis : {"monomial", "legendre", "chebyshev"}, optional
        Basis of the error motions; the machine definition's when omitted.
    prefer : sequence of str
        Terms the datum keeps first (:func:`~mtmetrology.cmm.models.choose_datum`).
    seed : int or Generator
        For the random points of U2 and U3.
    adequacy : {"scale", "a-priori"}
        The identification engine's model-adequacy rule: when the residuals contradict the
        model or σ (chi-squared p < 0.01) the covariance (and U1–U3) is scaled by s²
        (``"scale"``) or kept (``"a-priori"``).

    Returns
    -------
    BallPlateCalibration

    Raises
    ------
    RankDeficientError
        If the set-up cannot separate the model's terms; ``confounded`` names them.
    """
    choice = parse_model(model) if isinstance(model, str) else model
    machine, datum = model_machine(base, choice, basis, prefer)
    problem = BallPlateProblem(machine, records, plate, probes, sigma=sigma)
    check_design(problem, plate, probes)
    # ~10³ x 10² matrices: one BLAS thread is fastest and does not oversubscribe shared cores
    with threadpool_limits(1):
        res = levenberg_marquardt(problem, report_names=machine.parameter_names)
    res = res.with_adequacy(adequacy)
    pset = res.parameter_set(machine, {"method": "ball-plate calibration", "model": choice.name})
    summary = _summary(
        machine, pset.values, pset.covariance, res, problem, probes, as_generator(seed)
    )
    return BallPlateCalibration(machine, pset, res, problem, datum, choice.name, summary)


def check_design(problem: BallPlateProblem, plate: BallPlate, probes: ProbeSet):
    """Refuse a set-up whose *design* cannot separate the model's terms.

    Rank is judged on noise-free design readings (the calibrated plate in the start poses,
    read by the nominal machine): on the measured readings, reading noise turns an exact
    confounding (e.g. a Z scale error when every ball is at one height) into a tiny but
    non-zero singular value, which a relative tolerance would pass.

    Raises
    ------
    RankDeficientError
        Naming the unobservable combinations of error parameters.
    """
    m = problem.machine
    x0 = problem.initial()
    _, poses, balls = problem.split(x0)
    target = problem.plate_points(poses, balls)
    design = m.inverse(target, target - problem.tools, None, tool=problem.tools)
    rec = problem.records
    ideal = type(rec)(rec.positions, rec.balls, rec.probes, design, rec.lines)
    dp = BallPlateProblem(m, ideal, plate, probes, sigma=problem.sigma)
    _, jac = dp.evaluate(dp.initial())
    norms = np.linalg.norm(jac, axis=0)
    norms = np.where(norms > 0, norms, 1.0)
    with threadpool_limits(1):
        _, sv, vt = np.linalg.svd(jac / norms, full_matrices=False)
    report = analyse_identifiability(
        jac, dp.names, report_names=m.parameter_names, svd=(norms, sv, vt)
    )
    if not report.full_rank:
        raise RankDeficientError(
            f"this set-up cannot identify the {m.model_name or 'chosen'} model ({report.message}); "
            "add plate positions that separate them (vertical or tilted plates, other heights, "
            "styli in other directions) or choose a smaller model",
            confounded=report.confounded(),
        )
    return report


def _ball_blocks(records: BallPlateRecords, blocks: int, repeats: int, rng) -> np.ndarray:
    """Fold index of every indication, (repeats, n): the balls of each position are dealt
    at random into ``blocks`` blocks (a ball's styli stay together); a position keeps at
    least 3 balls in every fold (else it is never held out, index −1)."""
    pos, balls = np.array(records.positions), np.array(records.balls)
    out = np.full((repeats, len(pos)), -1)
    for r in range(repeats):
        for pid in records.position_ids:
            sel = pos == pid
            ids = np.unique(balls[sel])
            deal = rng.permutation(len(ids)) % blocks
            if len(ids) - np.bincount(deal).max() < 3:
                continue
            out[r, sel] = deal[np.searchsorted(ids, balls[sel])]
    return out


def _held_out_deviations(cal: BallPlateCalibration, held: BallPlateRecords, plate, probes):
    """Compensated held-out indications minus the fit's plate points ``T̂_l(ŷ_i)``, (n, 3).

    ``ŷ_i`` is the fit's ball centre when the ball was probed in another position (the
    self-calibrated plate), else the certificate's.
    """
    prob = cal.problem
    _, poses, balls = prob.split(cal.identification.estimate)
    known = {b: balls[k] for k, b in enumerate(prob.ball_ids)}
    y = np.array([known.get(b, plate.coordinates[plate.ids.index(b)]) for b in held.balls])
    lpos = np.array([prob.position_ids.index(p) for p in held.positions])
    v = np.einsum("nij,nj->ni", prob.rotations0[lpos], y)
    target = v + np.cross(poses[lpos, :3], v) + poses[lpos, 3:]
    return cal.compensate(held.readings, probes.offsets(held.probes)) - target


def cross_validate(
    base: Machine,
    records: BallPlateRecords,
    plate: BallPlate,
    probes: ProbeSet,
    candidates,
    *,
    sigma: float,
    blocks: int = 5,
    repeats: int = 1,
    seed=0,
    progress=None,
) -> dict:
    """Choose a model by cross-validation on blocks of balls held out in every position.

    The balls of each plate position are dealt at random into ``blocks`` blocks; fold k
    holds out block k of *every* position (all its styli) and fits the candidate to the
    rest, so every position stays in every fold and a model identifiable from the whole
    set-up stays identifiable (leaving a whole position out is not: with the standard
    three plates in the XY, XZ and YZ planes every full model is then rank deficient or
    extrapolates).  ``repeats`` deals again.  The held-out deviation of an indication is
    its compensated position minus the fitted plate point ``T̂_l(ŷ_i)`` (the fold's pose
    of the position and its estimate of the ball centre, the certificate's if the ball
    was seen nowhere else); a fold's score is the RMS of its deviations (coordinates).

    The candidates are those identifiable from all the records (a candidate the set-up
    cannot identify is reported, not chosen); they are compared on the folds where every
    one of them is identifiable, and the chosen model has the lowest median fold RMS
    (robust to one fold that extrapolates).  When fewer than two folds are common (no
    fair comparison), the choice is the lowest

        AIC = χ² + 2p,    χ² = Σ r_i² / σ²

    over the whole-data fits (``p`` unknowns, ``σ`` the stated reading uncertainty;
    Akaike 1974), and ``fair`` is False with the reason.  BIC = χ² + p ln m (m residual
    rows; Schwarz 1978) and the variance factor χ²/ν are reported beside it.

    Parameters
    ----------
    base : Machine
    records : BallPlateRecords
    plate : BallPlate
    probes : ProbeSet
    candidates : sequence of str or ModelChoice
    sigma : float
        Standard uncertainty of a reading coordinate, mm.
    blocks : int
        Number of ball blocks per deal (>= 2).
    repeats : int
        Number of deals.
    seed : int or Generator
        Of the deals.
    progress : callable, optional
        ``progress(done, total)`` before each fold's fit and at the end, ``total`` the
        fits of every candidate (the whole data and each fold), for a progress display.

    Returns
    -------
    dict
        ``{"method", "criterion" ("cross-validation" or "AIC"), "fair", "reason",
        "positions", "folds" (labels "deal.block"), "common_folds", "blocks", "repeats",
        "scores": [{"model", "full_rank", "fold_rms_um" (per fold, None if not
        identifiable), "rms_um" (per position, pooled over the common folds),
        "median_rms_um", "mean_rms_um" (pooled RMS; both None if not scored), "aic",
        "bic", "variance_factor", "n_unknowns", "identifiable_folds", "scored",
        "eligible"}], "chosen"}``; ``eligible`` marks the candidates the choice was made
        among.

    Raises
    ------
    RankDeficientError
        No candidate is identifiable from the records.

    References
    ----------
    Akaike, H. (1974). A new look at the statistical model identification. *IEEE Trans.
    Automatic Control* 19(6), 716–723.
    Schwarz, G. (1978). Estimating the dimension of a model. *Ann. Statist.* 6(2), 461–464.
    Hastie, T., Tibshirani, R. & Friedman, J. (2009). *The Elements of Statistical
    Learning*, 2nd ed., §7.10 (K-fold cross-validation).
    """
    if blocks < 2 or repeats < 1:
        raise ValueError(f"blocks >= 2 and repeats >= 1 expected, got {blocks}, {repeats}")
    positions = list(records.position_ids)
    deal = _ball_blocks(records, blocks, repeats, as_generator(seed))
    folds = [(r, k) for r in range(repeats) for k in range(blocks) if (deal[r] == k).any()]
    labels = [f"{r + 1}.{k + 1}" for r, k in folds]
    pos = np.array(records.positions)
    names, whole, dev = [], [], []
    per = 1 + len(folds)  # fits per candidate: the whole data, then every fold
    for i, cand in enumerate(candidates):
        names.append(cand if isinstance(cand, str) else cand.name)
        try:
            res = calibrate_ballplate(
                base, records, plate, probes, model=cand, sigma=sigma
            ).identification
        except RankDeficientError:
            whole.append(None)
            dev.append([None] * len(folds))
            continue
        whole.append(res)
        row = []
        for j, (r, k) in enumerate(folds):
            if progress is not None:
                progress(i * per + 1 + j, len(candidates) * per)
            held = deal[r] == k
            try:
                cal = calibrate_ballplate(
                    base, records.subset(~held), plate, probes, model=cand, sigma=sigma
                )
            except RankDeficientError:
                row.append(None)
                continue
            row.append(_held_out_deviations(cal, records.subset(held), plate, probes))
        dev.append(row)
    if progress is not None:
        progress(len(candidates) * per, len(candidates) * per)
    full = np.array([w is not None for w in whole])
    if not full.any():
        raise RankDeficientError(
            "no candidate model can be identified from these records: add plate positions "
            "or styli, or choose a smaller model"
        )
    ok = np.array([[d is not None for d in row] for row in dev], dtype=bool)
    common = ok[full].all(axis=0)
    fair = int(common.sum()) >= 2
    rms = np.full((len(names), len(folds)), np.nan)
    for i, row in enumerate(dev):
        for j, d in enumerate(row):
            if d is not None:
                rms[i, j] = float(from_internal(np.sqrt(np.mean(d**2)), "µm"))
    m = [len(w.residuals) if w is not None else 0 for w in whole]
    aic = np.array([2 * w.cost + 2 * len(w.names) if w is not None else np.inf for w in whole])
    scores = []
    for i, name in enumerate(names):
        w, scored = whole[i], bool(full[i] and fair)
        per_pos, pooled, median = [None] * len(positions), None, None
        if scored:
            cols = np.flatnonzero(common)
            d = np.concatenate([dev[i][j] for j in cols])
            at = np.concatenate([pos[deal[folds[j][0]] == folds[j][1]] for j in cols])
            pooled = float(from_internal(np.sqrt(np.mean(d**2)), "µm"))
            median = float(np.median(rms[i, cols]))
            per_pos = [
                float(from_internal(np.sqrt(np.mean(d[at == p] ** 2)), "µm"))
                if (at == p).any()
                else None
                for p in positions
            ]
        scores.append(
            {
                "model": name,
                "full_rank": bool(full[i]),
                "fold_rms_um": [None if np.isnan(v) else float(v) for v in rms[i]],
                "rms_um": per_pos,
                "median_rms_um": median,
                "mean_rms_um": pooled,
                "aic": float(aic[i]) if full[i] else None,
                "bic": float(2 * w.cost + len(w.names) * np.log(m[i])) if full[i] else None,
                "variance_factor": w.variance_factor if full[i] else None,
                "n_unknowns": len(w.names) if full[i] else None,
                "identifiable_folds": int(ok[i].sum()),
                "scored": scored,
                "eligible": bool(full[i]),
            }
        )
    if fair:
        key = [s["median_rms_um"] if s["scored"] else np.inf for s in scores]
        chosen = names[int(np.argmin(key))]
        reason = None
        method = (
            f"lowest median held-out RMS over {int(common.sum())} folds, each holding out "
            f"one of {blocks} random blocks of balls in every plate position "
            f"({repeats} deal{'s' if repeats > 1 else ''}); the fold's deviations are the "
            "compensated indications minus the fitted plate points"
        )
    else:
        chosen = names[int(np.argmin(aic))]
        reason = (
            f"only {int(common.sum())} of {len(folds)} ball-block folds leave every "
            "identifiable candidate identifiable: no fair held-out comparison"
        )
        method = (
            "lowest AIC (chi-square at the stated sigma + 2 x unknowns) over the whole-data "
            f"fits of the identifiable candidates, because {reason}"
        )
    return {
        "method": method,
        "criterion": "cross-validation" if fair else "AIC",
        "fair": fair,
        "reason": reason,
        "positions": positions,
        "folds": labels,
        "common_folds": [lab for lab, c in zip(labels, common, strict=True) if c],
        "blocks": blocks,
        "repeats": repeats,
        "scores": scores,
        "chosen": chosen,
    }
