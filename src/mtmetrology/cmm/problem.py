"""Observation model of ball-plate indications on a CMM (Salacheep 2016, eqs 4.10–4.13).

For indication k of ball i of the plate in position l, probed with stylus s, the residual is
(3 rows)::

    r_k = [ p(q_k; θ, t_s) − T_l(y_i) ] / σ
    T_l(y) = R0_l y + ω_l × (R0_l y) + τ_l

``p`` is the stylus-centre position of the kinematic engine (:class:`Machine`, error
parameters θ, tool vector t_s of the stylus), ``y_i`` the ball centre in the plate frame,
``(ω_l, τ_l)`` the small rotation and the translation of position l about a fixed rotation
``R0_l`` found once by a rigid (Kabsch) match of the nominal indications to the calibrated
plate.  The pose is linear in ω: the non-orthogonality of ``I + [ω]×`` is of order |ω|²,
which after the Kabsch start (|ω| ≲ 1e-5 rad) is below 1e-10 of the plate size.

The calibrated plate enters with its uncertainty as pseudo-observations (3 n_balls rows)::

    r_Y = L⁻¹ (y − y_cal),   L Lᵀ = U_Y (the certificate covariance)

so the ball centres are unknowns estimated together with θ and the poses (the source's
self-calibration, digest of Salacheep 2016 §2.5, with the certificate as prior instead of
the source's single "plate scale" constraint).  Probe offsets are taken as qualified
(known); a probe-qualification error is a constant offset per stylus and is absorbed by the
poses only when one stylus is used per position.

References
----------
Salacheep, P. (2016). *Error Compensation and Uncertainty Evaluation of CMMs Based on
Kinematic Error Models and Gaussian Processes*. MPhil thesis, Brunel University London,
eqs 4.9–4.13 and Appendix 2.
Kabsch, W. (1976). A solution for the best rotation to relate two sets of vectors.
*Acta Crystallographica* A32, 922–923.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.cmm.files import BallPlate, BallPlateRecords, ProbeSet
from mtmetrology.kinematics.machine import Machine

__all__ = ["BallPlateProblem", "kabsch", "skew"]


def skew(v: np.ndarray) -> np.ndarray:
    """``[v]×`` for vectors of shape (..., 3): ``skew(v) @ w == cross(v, w)``."""
    v = np.asarray(v, dtype=float)
    out = np.zeros((*v.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def kabsch(source: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation R and translation t minimising ``Σ‖R s + t − d‖²`` (Kabsch 1976).

    Parameters
    ----------
    source, target : ndarray, shape (n, 3), n >= 3 non-collinear

    Returns
    -------
    R : ndarray (3, 3), proper rotation
    t : ndarray (3,)

    Examples
    --------
    >>> s = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]])
    >>> r, t = kabsch(s, s[:, [1, 0, 2]] * [1, -1, 1])
    >>> np.round(r @ [1.0, 0, 0], 12).tolist()
    [0.0, -1.0, 0.0]
    """
    cs, ct = source.mean(axis=0), target.mean(axis=0)
    h = (source - cs).T @ (target - ct)
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    r = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return r, ct - r @ cs


class BallPlateProblem:
    """Weighted least squares of ball-plate indications (see the module notes).

    Parameters
    ----------
    machine : Machine
        The CMM with its active error parameters (the identified unknowns).
    records : BallPlateRecords
        Validated indications (readings in mm).
    plate : BallPlate
        Calibrated plate (centres and covariance).
    probes : ProbeSet
    sigma : float
        Standard uncertainty of one indication coordinate, mm.

    Attributes
    ----------
    names : tuple of str
        Machine parameters, ``pose <id> rx|ry|rz|x|y|z``, ``ball <id> x|y|z``.
    """

    def __init__(
        self,
        machine: Machine,
        records: BallPlateRecords,
        plate: BallPlate,
        probes: ProbeSet,
        *,
        sigma: float,
    ):
        if not (sigma > 0 and np.isfinite(sigma)):
            raise ValueError(f"sigma must be positive, got {sigma}")
        self.machine = machine
        self.records = records
        self.sigma = float(sigma)
        self.position_ids = records.position_ids
        self.ball_ids = tuple(b for b in plate.ids if b in set(records.balls))
        self._pos = np.array([self.position_ids.index(p) for p in records.positions])
        self._ball = np.array([self.ball_ids.index(b) for b in records.balls])
        self.tools = probes.offsets(records.probes)
        self.readings = np.asarray(records.readings, dtype=float)
        keep = np.concatenate(
            [[3 * plate.ids.index(b) + c for c in range(3)] for b in self.ball_ids]
        )
        self.y_cal = plate.coordinates[[plate.ids.index(b) for b in self.ball_ids]]
        cov = plate.covariance[np.ix_(keep, keep)]
        self._whiten = np.linalg.inv(np.linalg.cholesky(cov))  # r_Y = L⁻¹ (y − y_cal)
        self.n_params = machine.n_params
        self.n_positions = len(self.position_ids)
        self.n_balls = len(self.ball_ids)
        self.rotations0 = self._initial_rotations()
        pose_names = [
            f"pose {p} {c}" for p in self.position_ids for c in ("rx", "ry", "rz", "x", "y", "z")
        ]
        ball_names = [f"ball {b} {c}" for b in self.ball_ids for c in "xyz"]
        self.names = (*machine.parameter_names, *pose_names, *ball_names)

    # ------------------------------------------------------------------ layout
    @property
    def n_unknowns(self) -> int:
        return len(self.names)

    @property
    def n_rows(self) -> int:
        return 3 * self.readings.shape[0] + 3 * self.n_balls

    @property
    def residual_rounding(self) -> float:
        size = max(float(np.abs(self.readings).max(initial=0.0)), 1.0)
        return float(np.finfo(float).eps) * size / self.sigma

    @property
    def ball_slice(self) -> slice:
        start = self.n_params + 6 * self.n_positions
        return slice(start, start + 3 * self.n_balls)

    def split(self, x: np.ndarray):
        """(θ, poses (n_positions, 6) as [ω, τ], ball centres (n_balls, 3))."""
        p, npos = self.n_params, self.n_positions
        theta = x[:p]
        poses = x[p : p + 6 * npos].reshape(npos, 6)
        balls = x[self.ball_slice].reshape(self.n_balls, 3)
        return theta, poses, balls

    def _initial_rotations(self) -> np.ndarray:
        nominal = self.machine.forward(self.readings, None, tool=self.tools)
        out = np.empty((self.n_positions, 3, 3))
        self._t0 = np.empty((self.n_positions, 3))
        for l in range(self.n_positions):
            sel = self._pos == l
            balls = np.unique(self._ball[sel])
            mean = np.array([nominal[sel & (self._ball == b)].mean(axis=0) for b in balls])
            out[l], self._t0[l] = kabsch(self.y_cal[balls], mean)
        return out

    def initial(self, params: np.ndarray | None = None) -> np.ndarray:
        """Zero (or given) errors, Kabsch poses of the nominal indications, calibrated balls."""
        theta = np.zeros(self.n_params) if params is None else np.asarray(params, dtype=float)
        poses = np.zeros((self.n_positions, 6))
        poses[:, 3:] = self._t0
        return np.concatenate([theta, poses.ravel(), self.y_cal.ravel()])

    def plate_points(self, poses: np.ndarray, balls: np.ndarray) -> np.ndarray:
        """Machine-frame ball centres ``T_l(y_i)`` of every indication, shape (n, 3)."""
        v = np.einsum("nij,nj->ni", self.rotations0[self._pos], balls[self._ball])
        om, tau = poses[self._pos, :3], poses[self._pos, 3:]
        return v + np.cross(om, v) + tau

    # ------------------------------------------------------------------ residuals
    def evaluate(self, x: np.ndarray, jacobian: bool = True):
        """Weighted residuals (n_rows,) and optionally their Jacobian (n_rows, n_unknowns)."""
        theta, poses, balls = self.split(np.asarray(x, dtype=float))
        ev = self.machine.evaluate(self.readings, theta, tool=self.tools, d_params=jacobian)
        n = self.readings.shape[0]
        r_ind = (ev.position - self.plate_points(poses, balls)) / self.sigma
        r_prior = self._whiten @ (balls - self.y_cal).ravel()
        r = np.concatenate([r_ind.ravel(), r_prior])
        if not jacobian:
            return r, None
        p = self.n_params
        jac = np.zeros((self.n_rows, self.n_unknowns))
        jac[: 3 * n, :p] = ev.d_params.reshape(3 * n, p) / self.sigma
        v = np.einsum("nij,nj->ni", self.rotations0[self._pos], balls[self._ball])
        om = poses[self._pos, :3]
        # d(ω × v)/dω = −[v]×, so d r/dω = +[v]×/σ; d r/dτ = −I/σ
        blocks = np.zeros((n, 3, 6))
        blocks[:, :, :3] = skew(v) / self.sigma
        blocks[:, :, 3:] = -np.eye(3) / self.sigma
        # d r/dy = −(I + [ω]×) R0 / σ
        dball = -np.einsum("nij,njk->nik", np.eye(3) + skew(om), self.rotations0[self._pos])
        rows = np.arange(3 * n).reshape(n, 3)
        pose_cols = p + 6 * self._pos[:, None] + np.arange(6)
        ball_cols = self.ball_slice.start + 3 * self._ball[:, None] + np.arange(3)
        jac[rows[:, :, None], pose_cols[:, None, :]] = blocks
        jac[rows[:, :, None], ball_cols[:, None, :]] = dball / self.sigma
        jac[3 * n :, self.ball_slice] = self._whiten
        return r, jac
