"""Ball-plate calibration with the stylus offsets, and optionally the plate, as unknowns.

Extends the observation model of :mod:`mtmetrology.cmm.problem` (Salacheep 2016, §4.5,
Appendix 2) by the offset corrections ``Δp_k`` of every stylus and the centre ``s₀`` of a
reference sphere, and by the probe-qualification records as observations of their own::

    ball indication (position l, ball i, stylus k):  x*(q; θ, t_k + Δp_k) − T_l(y_i)
    qualification (stylus k on the sphere):          x*(q; θ, t_k + Δp_k) − s₀

each coordinate with standard uncertainty σ (``∂x*/∂t`` from the kinematic engine).  A
common shift of every stylus and of the sphere is absorbed by the plate poses, so the
stylus centroid is fixed, ``Σ_k Δp_k = 0`` (the source's constraint).  The plate enters
either through its certificate (the prior of :class:`BallPlateProblem`) or, with
``length``, self-calibrated: the ball centres are free but for one calibrated distance
``‖y_a − y_b‖ = L ± u(L)`` (the only scale), and the pose of the first position is fixed
(the plate frame).  Constraints enter as pseudo-observations of standard deviation εσ,
ε = 1e-3 (:data:`CONSTRAINT_EPS`).

References
----------
Salacheep, P. (2016). *Error Compensation and Uncertainty Evaluation of CMMs Based on
Kinematic Error Models and Gaussian Processes*. MPhil thesis, Brunel University London,
§4.4–4.5, Appendix 2 (probe qualification, centroid and scale constraints).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from threadpoolctl import threadpool_limits

from mtmetrology.cmm.calibrate import model_machine
from mtmetrology.cmm.files import BallPlate, BallPlateRecords, ProbeSet
from mtmetrology.cmm.models import parse_model
from mtmetrology.cmm.notebook import CMMNotebookRepr
from mtmetrology.cmm.problem import BallPlateProblem
from mtmetrology.errors import InputError, RankDeficientError
from mtmetrology.identification.diagnostics import analyse_identifiability
from mtmetrology.identification.solver import levenberg_marquardt
from mtmetrology.io.plausibility import check_scale
from mtmetrology.kinematics.machine import Machine
from mtmetrology.units import from_internal

__all__ = ["CalibratedLength", "ProbeCalibration", "calibrate_with_probes", "check_design"]

KIND = "cmm-probe-plate-calibration"
VERSION = 1
#: Constraint rows weigh 1/ε against a reading: the fixed directions are exact gauge
#: freedoms, so any weight gives the same solution; 1e-3 leaves them a variance of 1e-6 σ²
#: and keeps the column-scaled rank test of the solver meaningful (a weight of 1e9 would
#: drown the data in the columns it touches).
CONSTRAINT_EPS = 1e-3


@dataclass(frozen=True)
class CalibratedLength:
    """One calibrated distance between two balls: the only scale of a self-calibrated plate.

    Attributes
    ----------
    ball_a, ball_b : str
    length : float
        mm.
    u : float
        Standard uncertainty, mm.
    """

    ball_a: str
    ball_b: str
    length: float
    u: float


class ProbePlateProblem(BallPlateProblem):
    """:class:`BallPlateProblem` with stylus offsets, sphere centre and qualification rows.

    Parameters
    ----------
    machine, records, plate, probes, sigma
        As for :class:`BallPlateProblem`.
    qualification : BallPlateRecords
        Readings of the reference sphere (``ball`` ignored), one or more per stylus.
    length : CalibratedLength, optional
        Self-calibrate the plate with this one length; the certificate otherwise.
    """

    def __init__(self, machine, records, plate, probes, *, sigma, qualification, length=None):
        super().__init__(machine, records, plate, probes, sigma=sigma)
        self.probe_ids = tuple(dict.fromkeys((*records.probes, *qualification.probes)))
        self._tools0 = self.tools.copy()
        self._k = np.array([self.probe_ids.index(p) for p in records.probes])
        self._qk = np.array([self.probe_ids.index(p) for p in qualification.probes])
        self._q_tools = probes.offsets(qualification.probes)
        self._q_readings = np.asarray(qualification.readings, dtype=float)
        self.qualification = qualification
        self.length = length
        if length is not None:
            for b in (length.ball_a, length.ball_b):
                if b not in self.ball_ids:
                    raise InputError(f"length: ball {b!r} is not in the records")
            if {length.ball_a, length.ball_b} <= set(plate.ids):
                xyz = plate.coordinates
                a, b = plate.ids.index(length.ball_a), plate.ids.index(length.ball_b)
                # the plate's nominal distance: a length in m or µm is 10³ off it
                check_scale(
                    length.length,
                    float(np.linalg.norm(xyz[b] - xyz[a])),
                    f"--length: {length.ball_a}-{length.ball_b}",
                    against="the plate's nominal distance",
                )
        self._inner = len(self.names)  # θ, poses, balls: the base class's block
        extra = [f"probe {k} d{c}" for k in self.probe_ids for c in "xyz"]
        self.names = (*self.names, *extra, "sphere x", "sphere y", "sphere z")

    @property
    def n_unknowns(self) -> int:
        """Unknowns of the ball-plate block (θ, poses, balls) that the base class fills."""
        return self._inner

    def initial(self, params=None) -> np.ndarray:
        x = super().initial(params)
        q = self.machine.forward(self._q_readings, None, tool=self._q_tools)
        return np.concatenate([x, np.zeros(3 * len(self.probe_ids)), q.mean(axis=0)])

    def split_probes(self, x):
        """(offset corrections (n_probes, 3), sphere centre (3,))."""
        n = self._inner
        return x[n : n + 3 * len(self.probe_ids)].reshape(-1, 3), x[-3:]

    def evaluate(self, x, jacobian: bool = True):
        x = np.asarray(x, dtype=float)
        dp, sphere = self.split_probes(x)
        self.tools = self._tools0 + dp[self._k]
        r, j = super().evaluate(x[: self._inner], jacobian)
        n_ind = 3 * len(self.readings)
        theta = x[: self.n_params]
        tq = self._q_tools + dp[self._qk]
        ev = self.machine.evaluate(self._q_readings, theta, tool=tq, d_params=True, d_tool=jacobian)
        r_q = ((ev.position - sphere) / self.sigma).ravel()
        w = 1.0 / (CONSTRAINT_EPS * self.sigma)
        r_c = w * dp.sum(axis=0)
        rows = [r[:n_ind]]
        if self.length is None:
            rows.append(r[n_ind:])
        else:
            _, poses, balls = self.split(x[: self._inner])
            r_plate, j_plate = self._plate_frame_and_length(poses, balls, w)
            rows.append(r_plate)
        r_all = np.concatenate([*rows, r_q, r_c])
        if not jacobian:
            return r_all, None
        n, npr = len(self.names), len(self.probe_ids)
        out = np.zeros((len(r_all), n))
        out[:n_ind, : self._inner] = j[:n_ind]
        # indications: ∂/∂Δp_k = ∂x*/∂t of each record
        ev_i = self.machine.evaluate(
            self.readings, theta, tool=self.tools, d_params=True, d_tool=True
        )
        rows_i = np.arange(n_ind).reshape(-1, 3)
        cols_i = self._inner + 3 * self._k[:, None] + np.arange(3)
        out[rows_i[:, :, None], cols_i[:, None, :]] = ev_i.d_tool / self.sigma
        start = n_ind
        if self.length is None:
            out[start : start + 3 * self.n_balls, : self._inner] = j[n_ind:]
            start += 3 * self.n_balls
        else:
            out[start : start + 7, : self._inner] = j_plate
            start += 7
        nq = len(self._q_readings)
        rows_q = start + np.arange(3 * nq).reshape(-1, 3)
        out[start : start + 3 * nq, : self.n_params] = ev.d_params.reshape(3 * nq, -1) / self.sigma
        cols_q = self._inner + 3 * self._qk[:, None] + np.arange(3)
        out[rows_q[:, :, None], cols_q[:, None, :]] = ev.d_tool / self.sigma
        out[start : start + 3 * nq, -3:] = np.tile(-np.eye(3) / self.sigma, (nq, 1))
        start += 3 * nq
        for k in range(npr):
            out[start : start + 3, self._inner + 3 * k : self._inner + 3 * k + 3] = w * np.eye(3)
        return r_all, out

    def _plate_frame_and_length(self, poses, balls, w):
        """Rows fixing the first position's pose (6) and the one calibrated length (1)."""
        x0 = super().initial()
        _, poses0, _ = self.split(x0)
        r = np.empty(7)
        j = np.zeros((7, self._inner))
        r[:6] = w * (poses[0] - poses0[0])
        j[:6, self.n_params : self.n_params + 6] = w * np.eye(6)
        a, b = self.ball_ids.index(self.length.ball_a), self.ball_ids.index(self.length.ball_b)
        d = balls[a] - balls[b]
        dist = np.linalg.norm(d)
        r[6] = (dist - self.length.length) / self.length.u
        g = d / dist / self.length.u
        s = self.ball_slice.start
        j[6, s + 3 * a : s + 3 * a + 3] = g
        j[6, s + 3 * b : s + 3 * b + 3] = -g
        return r, j


def check_design(prob: ProbePlateProblem, plate, probes) -> None:
    """Refuse a set-up whose *design* leaves directions free (see
    :func:`mtmetrology.cmm.calibrate.check_design`: rank on noise-free readings, where an
    exact confounding is not hidden by the noise).

    Raises
    ------
    RankDeficientError
        Naming the free combinations of error parameters, offsets and plate unknowns.
    """
    m = prob.machine
    x0 = prob.initial()
    _, poses, balls = prob.split(x0[: prob._inner])
    target = prob.plate_points(poses, balls)
    sphere = np.broadcast_to(x0[-3:], prob._q_tools.shape)
    rec, qual = prob.records, prob.qualification
    ideal = BallPlateRecords(
        rec.positions, rec.balls, rec.probes,
        m.inverse(target, target - prob._tools0, None, tool=prob._tools0), rec.lines,
    )  # fmt: skip
    ideal_q = BallPlateRecords(
        qual.positions, qual.balls, qual.probes,
        m.inverse(sphere, sphere - prob._q_tools, None, tool=prob._q_tools), qual.lines,
    )  # fmt: skip
    dp = ProbePlateProblem(
        m, ideal, plate, probes, sigma=prob.sigma, qualification=ideal_q, length=prob.length
    )
    _, jac = dp.evaluate(dp.initial())
    report = analyse_identifiability(jac, dp.names, report_names=m.parameter_names)
    if not report.full_rank:
        raise RankDeficientError(
            f"this set-up leaves directions free ({report.message}); add plate positions in "
            "other planes or heights, qualify every stylus, or give the plate's certificate",
            confounded=report.confounded(),
        )


@dataclass(frozen=True)
class ProbeCalibration(CMMNotebookRepr):
    """Result of :func:`calibrate_with_probes`.

    Attributes
    ----------
    model : str
    parameters : dict
        ``{name: [value, u]}`` of the error parameters, internal units (mm, rad).
    probes : dict
        ``{id: {"offset_mm", "correction_um", "u_um"}}``: the estimated offsets.
    balls : dict
        ``{id: {"xyz_mm", "u_um"}}``: the estimated ball centres (plate frame).
    plate : str
        ``certificate`` or ``one length <a>-<b>``.
    fit : dict
        ``rms_residual_um, variance_factor, dof, message``.
    """

    model: str
    parameters: dict
    probes: dict
    balls: dict
    plate: str
    fit: dict

    def to_dict(self) -> dict:
        """File form (version 1)."""
        return {
            "kind": KIND,
            "version": VERSION,
            "model": self.model,
            "plate": self.plate,
            "parameters": self.parameters,
            "probes": self.probes,
            "balls": self.balls,
            "fit": self.fit,
        }

    @classmethod
    def from_dict(cls, doc: dict) -> ProbeCalibration:
        """Read :meth:`to_dict`'s form back."""
        if doc.get("kind") != KIND or doc.get("version") != VERSION:
            raise InputError(f"probe calibration: expected kind {KIND!r} version {VERSION}")
        return cls(
            doc["model"], doc["parameters"], doc["probes"], doc["balls"], doc["plate"], doc["fit"]
        )


def calibrate_with_probes(
    base: Machine,
    records: BallPlateRecords,
    plate: BallPlate,
    probes: ProbeSet,
    qualification: BallPlateRecords,
    *,
    sigma: float,
    model="seed",
    length: CalibratedLength | None = None,
) -> ProbeCalibration:
    """Identify the error parameters with the stylus offsets (and the plate) as unknowns.

    Parameters
    ----------
    base : Machine
    records : BallPlateRecords
    plate : BallPlate
        Nominal or calibrated centres (the start; the prior unless ``length`` is given).
    probes : ProbeSet
        Nominal stylus offsets (the start).
    qualification : BallPlateRecords
        Readings of the reference sphere with each stylus.
    sigma : float
        Standard uncertainty of a reading coordinate, mm.
    model : str or ModelChoice
    length : CalibratedLength, optional
        Self-calibrate the plate with this one length as its only scale.

    Returns
    -------
    ProbeCalibration

    Raises
    ------
    RankDeficientError
        Naming what the set-up leaves free (e.g. a stylus never qualified nor used in two
        directions).
    InputError
        A stylus of the records that has no qualification record, or a length ball missing.
    """
    missing = sorted(set(records.probes) - set(qualification.probes))
    if missing:
        raise InputError(f"qualification: no record of stylus {', '.join(missing)}")
    choice = parse_model(model) if isinstance(model, str) else model
    machine, _ = model_machine(base, choice)
    prob = ProbePlateProblem(
        machine, records, plate, probes, sigma=sigma, qualification=qualification, length=length
    )
    with threadpool_limits(1):
        check_design(prob, plate, probes)
        res = levenberg_marquardt(prob, report_names=prob.names[: machine.n_params])
    x, u = res.estimate, np.sqrt(np.clip(np.diag(res.covariance), 0.0, None))
    p = machine.n_params
    params = {n: [float(x[i]), float(u[i])] for i, n in enumerate(machine.parameter_names)}
    dp, _ = prob.split_probes(x)
    out_probes = {}
    for k, pid in enumerate(prob.probe_ids):
        cols = prob._inner + 3 * k + np.arange(3)
        out_probes[pid] = {
            "offset_mm": (probes.offsets([pid])[0] + dp[k]).tolist(),
            "correction_um": from_internal(dp[k], "µm").tolist(),
            "u_um": from_internal(u[cols], "µm").tolist(),
        }
    s = prob.ball_slice.start
    balls = {
        b: {
            "xyz_mm": x[s + 3 * i : s + 3 * i + 3].tolist(),
            "u_um": from_internal(u[s + 3 * i : s + 3 * i + 3], "µm").tolist(),
        }
        for i, b in enumerate(prob.ball_ids)
    }
    n_ind = 3 * len(records.readings)
    fit = {
        "rms_residual_um": float(
            from_internal(np.sqrt(np.mean(res.residuals[:n_ind] ** 2)) * sigma, "µm")
        ),
        "variance_factor": res.variance_factor,
        "dof": res.dof,
        "message": res.message,
        "n_parameters": p,
    }
    label = "certificate" if length is None else f"one length {length.ball_a}-{length.ball_b}"
    return ProbeCalibration(choice.name, params, out_probes, balls, label, fit)
