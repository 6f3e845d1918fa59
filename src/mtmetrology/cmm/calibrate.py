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
from mtmetrology.cmm.problem import BallPlateProblem, kabsch
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
    "ABSURD_FACTOR",
    "CHECK_FACTOR",
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


def _held_out_rms(cal: BallPlateCalibration, records: BallPlateRecords, plate, probes) -> float:
    """RMS (mm) of the held-out indications after compensation and a rigid fit to the plate."""
    tools = probes.offsets(records.probes)
    pts = cal.compensate(records.readings, tools)
    y = plate.coordinates[[plate.ids.index(b) for b in records.balls]]
    r, t = kabsch(y, pts)
    return float(np.sqrt(np.mean((pts - (y @ r.T + t)) ** 2)))


#: A fold whose held-out RMS exceeds this many times the fold's reference (the best
#: candidate on that fold, or the candidate's own median fold if smaller) is absurd: the
#: model, fitted without that position, extrapolates (1 885 µm was seen against ~1 µm).
ABSURD_FACTOR = 10.0
#: The candidate with the lowest AIC is chosen among those whose robust held-out score is
#: within this factor of the best (the criterion checked against held-out data).
CHECK_FACTOR = 1.25


def cross_validate(
    base: Machine,
    records: BallPlateRecords,
    plate: BallPlate,
    probes: ProbeSet,
    candidates,
    *,
    sigma: float,
) -> dict:
    """Choose a model by AIC, checked against leave-one-position-out held-out scores.

    For each candidate and each plate position, the model is identified without that
    position; the held-out indications are compensated, fitted rigidly to the calibrated
    plate, and the RMS of the remaining deviations is the fold's score.  A fold decides
    nothing when

    - its reduced set-up is rank deficient for the candidate (status ``rank-deficient``:
      the model cannot be identified without that position), or
    - its RMS exceeds :data:`ABSURD_FACTOR` times the fold's reference (status ``absurd``:
      the model extrapolates from the other positions), the reference being the smaller of
      the best RMS of any candidate on that fold and the candidate's median fold RMS.

    A candidate is scored when at least half its folds are usable (status ``ok``); the
    scored candidates are compared on their *common* usable folds (while fewer than two
    remain, the scored candidate with the fewest usable folds is dropped).  The held-out
    score is the median RMS over those folds (robust: one fold that extrapolates does not
    decide); the mean is reported too.  Each candidate is also fitted to all the records:

        AIC = χ² + 2p,    χ² = Σ r_i² / σ²

    (``p`` unknowns, ``σ`` the stated reading uncertainty).  The chosen model has the lowest
    AIC among the scored candidates whose held-out score is within :data:`CHECK_FACTOR` of
    the best: leave-one-position-out folds alone favour small models (each fold
    extrapolates to a position), the AIC alone trusts ``σ``.  A candidate with an absurd
    fold is flagged (``absurd``) whatever its score.

    Returns
    -------
    dict
        ``{"method", "positions", "common_folds", "absurd_factor", "check_factor",
        "scores": [{"model", "rms_um": [per fold, None if rank deficient], "status": [per
        fold], "median_rms_um", "mean_rms_um" (None if not scored), "aic", "n_unknowns",
        "scored", "eligible", "absurd"}], "chosen"}``

    References
    ----------
    Akaike, H. (1974). A new look at the statistical model identification. *IEEE Trans.
    Automatic Control* 19(6), 716–723.
    """
    positions = list(records.position_ids)
    names, rms, aic, n_unknowns = [], [], [], []
    for cand in candidates:
        names.append(cand if isinstance(cand, str) else cand.name)
        try:
            res = calibrate_ballplate(
                base, records, plate, probes, model=cand, sigma=sigma
            ).identification
            aic.append(2.0 * res.cost + 2.0 * len(res.names))
            n_unknowns.append(len(res.names))
        except RankDeficientError:
            aic.append(np.inf)
            n_unknowns.append(None)
        row = []
        for pid in positions:
            held = np.array([p == pid for p in records.positions])
            try:
                cal = calibrate_ballplate(
                    base, records.subset(~held), plate, probes, model=cand, sigma=sigma
                )
            except RankDeficientError:
                row.append(np.nan)
                continue
            row.append(
                float(from_internal(_held_out_rms(cal, records.subset(held), plate, probes), "µm"))
            )
        rms.append(row)
    rms = np.array(rms, dtype=float).reshape(len(names), len(positions))
    aic = np.array(aic)
    with np.errstate(all="ignore"):
        best = np.nanmin(np.where(np.isfinite(rms), rms, np.inf), axis=0)  # per fold
        own = np.array([np.nanmedian(r) if np.isfinite(r).any() else np.inf for r in rms])
        reference = np.minimum(best[None, :], own[:, None])
    absurd = np.isfinite(rms) & (rms > ABSURD_FACTOR * reference)
    usable = np.isfinite(rms) & ~absurd
    status = np.where(~np.isfinite(rms), "rank-deficient", np.where(absurd, "absurd", "ok"))
    scored = usable.sum(axis=1) >= max(1, len(positions) / 2)
    common = usable[scored].all(axis=0) if scored.any() else np.zeros(len(positions), bool)
    while scored.sum() > 1 and common.sum() < 2:
        worst = np.flatnonzero(scored)[np.argmin(usable[scored].sum(axis=1))]
        scored[worst] = False
        common = usable[scored].all(axis=0)
    if not scored.any() or not common.any():
        raise RankDeficientError(
            "no candidate model can be cross-validated: each is rank deficient or absurd when "
            "plate positions are left out; add positions or choose --model explicitly"
        )
    scored &= np.isfinite(aic)
    median = np.where(scored, np.median(rms[:, common], axis=1), np.nan)
    mean = np.where(scored, rms[:, common].mean(axis=1), np.nan)
    eligible = scored & (median <= CHECK_FACTOR * np.nanmin(median))
    scores = [
        {
            "model": name,
            "rms_um": [None if not np.isfinite(v) else float(v) for v in rms[i]],
            "status": [str(v) for v in status[i]],
            "median_rms_um": float(median[i]) if scored[i] else None,
            "mean_rms_um": float(mean[i]) if scored[i] else None,
            "aic": float(aic[i]) if np.isfinite(aic[i]) else None,
            "n_unknowns": n_unknowns[i],
            "scored": bool(scored[i]),
            "eligible": bool(eligible[i]),
            "absurd": bool(absurd[i].any()),
        }
        for i, name in enumerate(names)
    ]
    chosen = names[int(np.argmin(np.where(eligible, aic, np.inf)))]
    return {
        "method": "lowest AIC (chi-square at the stated sigma + 2 x unknowns) among the "
        f"candidates whose held-out score is within {CHECK_FACTOR:g} x the best; held-out "
        "score: median RMS after a rigid fit of the leave-one-position-out folds usable by "
        "every scored candidate",
        "positions": positions,
        "common_folds": [p for p, c in zip(positions, common, strict=True) if c],
        "absurd_factor": ABSURD_FACTOR,
        "check_factor": CHECK_FACTOR,
        "scores": scores,
        "chosen": chosen,
    }
