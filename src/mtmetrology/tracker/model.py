"""The identification problem of a tracker verification: error functions and tracker pose.

Measurement model (Aguado et al. (2019), eq. 2): the tracker sees the tool tip of the
machine at commanded readings ``q_i`` with tool offset ``t_i`` at::

    p_LT,i = Rᵀ(α, β, δ)·(f(q_i, t_i; θ) − T)

with ``f`` the machine's forward kinematics and its error parameters θ (the kinematic
engine: 18 error functions and 3 squareness errors of the XFYZ preset), ``(T, α, β, δ)`` the
tracker pose.  The unknowns are θ (the identifiable subset, :func:`datum`) and the six pose
components, identified jointly in one phase by weighted least squares through the one core
(:func:`mtmetrology.identification.levenberg_marquardt`); the residuals are whitened by the
per-point covariance ``Σ_i`` (tracker noise J Σ Jᵀ, SMR, and the axis repeatability and
thermal-correction variances), ``r_i = L_i⁻¹(p_LT,i(x) − p_meas,i)`` with ``Σ_i = L_i L_iᵀ``.

The registration that starts it (eqs 25–26) is the rigid least-squares fit of the measured
points to the nominal ones (Arun, Huang and Blostein (1987); SVD, det-corrected).  The
eq. 27 metric, the mean distance between nominal and measured points, is reported before
and after compensation; it is not the objective (the paper does not say it is minimised,
and the mean of norms has no covariance to report).

References
----------
S. Aguado et al., *Sensors* 19 (2019) 2847, eqs 2, 25–27.
K. S. Arun, T. S. Huang, S. D. Blostein, "Least-squares fitting of two 3-D point sets",
IEEE Trans. PAMI 9 (1987) 698–700.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.identification.datum import (
    Datum,
    SetupTerms,
    choose_datum,
    constant_rotation_candidates,
    exposed_terms,
)
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.tracker import TrackerPose, euler_angles, euler_matrix

__all__ = [
    "POSE_NAMES",
    "TrackerProblem",
    "datum",
    "mean_distance",
    "register",
    "setup_terms",
    "suggestions",
]

#: Names of the pose unknowns: position along machine x, y, z (mm), Euler angles (rad).
POSE_NAMES = ("D", "L", "H", "alpha", "beta", "delta")


def register(nominal: np.ndarray, measured_tracker: np.ndarray) -> TrackerPose:
    """The pose that best maps tracker-frame points onto nominal machine points (eqs 25–26).

    Minimises ``Σ‖R p_LT,i + T − p_i‖²`` over rotations R and translations T (closed form,
    SVD of the cross-covariance with the reflection removed).
    """
    a = np.asarray(measured_tracker, dtype=float)
    b = np.asarray(nominal, dtype=float)
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    rot = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return TrackerPose(cb - rot @ ca, euler_angles(rot))


def mean_distance(a: np.ndarray, b: np.ndarray) -> float:
    """Eq. 27: ``(1/n)·Σ‖a_i − b_i‖``, mm."""
    return float(np.mean(np.linalg.norm(np.asarray(a) - np.asarray(b), axis=-1)))


def whitening(covariance: np.ndarray) -> np.ndarray:
    """``L⁻¹`` (n, 3, 3) of per-point covariances ``Σ = L Lᵀ``.

    Raises
    ------
    InputError
        If a covariance is singular (a noise model of zero uncertainty cannot weight).
    """
    try:
        return np.linalg.inv(np.linalg.cholesky(covariance))
    except np.linalg.LinAlgError:
        raise InputError(
            "noise: the tracker noise model gives a singular point covariance; give a "
            "positive range, angle or SMR uncertainty"
        ) from None


def tracker_points(machine_points: np.ndarray, pose_vectors: np.ndarray) -> np.ndarray:
    """``Rᵀ(p − T)`` for K poses at once: points (K, n, 3), poses (K, 6) → (K, n, 3)."""
    x = np.asarray(pose_vectors, dtype=float)
    rot = euler_matrix(x[:, 3], x[:, 4], x[:, 5])  # (K, 3, 3)
    return np.einsum("kni,kij->knj", machine_points - x[:, None, :3], rot)


@dataclass(frozen=True, eq=False)
class TrackerProblem:
    """Weighted least squares of θ and the pose (module notes); the solver's problem object.

    Attributes
    ----------
    machine : Machine
        With the parameters to identify active (the datum).
    readings, tools : (n, 3) ndarray
        Commanded readings (thermally corrected) and tool offsets, mm.
    measured : (n, 3) ndarray
        Measured points in the tracker frame, mm.
    weights : (n, 3, 3) ndarray
        ``L_i⁻¹`` of the point covariances.
    start : TrackerPose
        Starting pose (the registration), or the known pose.
    pose_fixed : bool
        The pose is known exactly: not an unknown (``start`` is used as it is).
    pose_prior : (6, 6) ndarray or None
        ``L⁻¹`` of the covariance of a known pose ``start`` used as a prior: six more
        residuals ``L⁻¹·(x_pose − start)`` (a pseudo-observation of the pose, the Bayesian
        reading of a Gaussian prior in least squares).
    """

    machine: Machine
    readings: np.ndarray
    tools: np.ndarray
    measured: np.ndarray
    weights: np.ndarray
    start: TrackerPose
    pose_fixed: bool = False
    pose_prior: np.ndarray | None = None

    @property
    def names(self) -> tuple[str, ...]:
        return (*self.machine.parameter_names, *(() if self.pose_fixed else POSE_NAMES))

    @property
    def n_rows(self) -> int:
        return self.measured.size + (6 if self.pose_prior is not None else 0)

    @property
    def residual_rounding(self) -> float:
        return float(np.finfo(float).eps * np.abs(self.measured).max() * np.abs(self.weights).max())

    def initial(self) -> np.ndarray:
        pose = () if self.pose_fixed else self.start.vector
        return np.concatenate([np.zeros(self.machine.n_params), pose])

    def pose_of(self, x: np.ndarray) -> TrackerPose:
        """The pose at the unknowns ``x`` (the known one when it is fixed)."""
        if self.pose_fixed:
            return self.start
        return TrackerPose.from_vector(x[self.machine.n_params :])

    def model(self, x: np.ndarray, jacobian: bool = True):
        """Predicted tracker-frame points (n, 3) and ∂/∂x (n, 3, n_unknowns)."""
        n = self.machine.n_params
        pose = self.pose_of(x)
        ev = self.machine.evaluate(self.readings, x[:n], tool=self.tools, d_params=jacobian)
        p = pose.to_tracker(ev.position)
        if not jacobian:
            return p, None
        d_theta = np.einsum("ji,njk->nik", pose.rotation, ev.d_params)
        if self.pose_fixed:
            return p, d_theta
        return p, np.concatenate([d_theta, pose.jacobian(ev.position)], axis=-1)

    def evaluate(self, x: np.ndarray, jacobian: bool = True):
        p, jac = self.model(x, jacobian)
        r = np.einsum("nij,nj->ni", self.weights, p - self.measured).ravel()
        if jacobian:
            jac = np.einsum("nij,njk->nik", self.weights, jac).reshape(r.size, -1)
        if self.pose_prior is not None:
            n = self.machine.n_params
            r = np.concatenate([r, self.pose_prior @ (x[n:] - self.start.vector)])
            if jacobian:
                jac = np.vstack([jac, np.hstack([np.zeros((6, n)), self.pose_prior])])
        return r, jac


def _setup_jacobian(
    machine: Machine, readings, tools, pose: TrackerPose, fixed_pose: bool = False
) -> np.ndarray:
    ev = machine.evaluate(readings, tool=tools, d_params=True)
    d_theta = np.einsum("ji,njk->nik", pose.rotation, ev.d_params)
    if fixed_pose:
        return d_theta.reshape(-1, d_theta.shape[-1])
    jac = np.concatenate([d_theta, pose.jacobian(ev.position)], axis=-1)
    return jac.reshape(-1, jac.shape[-1])


def datum(
    machine: Machine,
    readings,
    tools,
    pose: TrackerPose,
    rtol: float = 1e-7,
    fixed_pose: bool = False,
) -> Datum:
    """What a set-up can identify: the generic datum choice on its Jacobian.

    With ``fixed_pose`` the pose is known and not a nuisance unknown (a pose known only
    to its prior uncertainty is still one: the datum is what the readings alone see).

    The paper's mesh with one tool offset along Z and the 21-function model: rank 42 of 57
    (E_CY1–3 and E_CZ1–3 not seen; E_ZZ3 ~ E_ZZ1 with three Z levels; E_XZ2 ~ E_BZ2 and
    E_YZ2 ~ E_AZ2 through the tool length; the Z-axis tilts ~ squareness + pose).
    """
    jac = _setup_jacobian(machine, readings, tools, pose, fixed_pose)
    nuisance = () if fixed_pose else POSE_NAMES
    return choose_datum(jac, machine.parameter_names, nuisance=nuisance, rtol=rtol)


def setup_terms(
    machine: Machine,
    base: Datum,
    readings,
    tools,
    pose: TrackerPose,
    rtol: float = 1e-7,
    fixed_pose: bool = False,
) -> SetupTerms:
    """The constants of the tool-side axes this set-up exposes beyond the datum ``base``.

    The degree-0 angular terms the model leaves out
    (:func:`~mtmetrology.identification.datum.constant_rotation_candidates`) checked by rank
    against the datum's and the pose's columns
    (:func:`~mtmetrology.identification.datum.exposed_terms`).  With one tool along Z they
    are all absorbed (a constant rotation ε moves the tip by the constant ε × t, a shift of
    the pose); with laterally offset tools on the paper's three Z levels the tool's yaw
    E_CZ0 is exposed (E_AZ0 and E_BZ0 stay absorbed by the pose, the squarenesses and Z's
    cubic straightness, a line on three levels), on five Z levels its pitch and roll too.
    """
    return exposed_terms(
        lambda m: _setup_jacobian(m, readings, tools, pose, fixed_pose),
        machine.with_parameters(base.kept),
        () if fixed_pose else POSE_NAMES,
        candidates=constant_rotation_candidates(machine),
        rtol=rtol,
    )


def suggestions(
    machine: Machine,
    mesh: np.ndarray,
    tools: np.ndarray,
    pose: TrackerPose,
    base: Datum,
    fixed_pose: bool = False,
) -> list[dict]:
    """What to add to a set-up to see what it cannot: a second, lateral tool offset; more Z
    levels (every quarter of the Z travel); both.  Each entry names the parameters the
    addition makes identifiable and the rank it reaches."""
    if not base.dropped:
        return []
    tools = np.atleast_2d(tools)
    lateral = tools[0] + np.array([100.0, 100.0, 0.0])
    lo, hi = machine.axes["Z"].travel
    levels = np.linspace(lo, hi, 5)
    xy = np.unique(mesh[:, :2], axis=0)
    deeper = np.array([[x, y, z] for z in levels for x, y in xy])
    options = {
        "a second tool offset 100 mm aside in X and Y": (mesh, np.vstack([tools, lateral])),
        "five Z levels over the travel": (deeper, tools),
        "both": (deeper, np.vstack([tools, lateral])),
    }
    out = []
    for what, (m, t) in options.items():
        q = np.repeat(m, len(t), axis=0)
        tt = np.tile(t, (len(m), 1))
        d = datum(machine, q, tt, pose, fixed_pose=fixed_pose)
        gained = [n for n in base.dropped_names if n not in d.dropped_names]
        out.append({"add": what, "rank": d.rank, "identifiable_then": gained})
    return out
