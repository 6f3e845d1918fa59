"""Gaussian-process error model of a CMM, trained through the ball-plate observation model.

Model (Salacheep 2016, §5.2, eqs 5.1–5.10, with the GPML mean of §5.3)::

    p_true(q, t) = p(q; θ̂, t) − f(q, t),     f_c ~ GP(0, k_c) for each component c = x, y, z
    k_c(a, b) = s_c² ρ(‖(a − b)/ℓ_c‖) + σ_c² δ_ab

``p(q; θ̂, t)`` is the kinematic model (the *polynomial mean*: Chebyshev error functions
identified by :func:`~mtmetrology.cmm.calibrate.calibrate_ballplate`), or the nominal
kinematics for a zero-mean GP; ``ρ`` is the squared exponential (``rbf``) or Matérn ν = 5/2
(``matern``) correlation of the axis readings X, Y, Z (mm) with one length-scale (the source's
``covSEiso``); the stylus enters through the kinematic mean; ``σ_c²`` the noise.  The
hyper-parameters ``s_c, ℓ_c, σ_c`` maximise the marginal likelihood (type-II ML, L-BFGS-B
in scikit-learn).

Training through the observation model, alternating: the plate poses cannot be
estimated jointly with a non-parametric f (a rigid motion of every position is absorbed by
f otherwise), so the fit alternates (i) the GP targets ``d_k = p(q_k; θ̂, t_k) − T_l(y_i)``
with poses T_l fixed, and (ii) the poses by a rigid (Kabsch) fit of the GP-compensated
indications to the ball centres, starting from the poses of the kinematic fit (joint with
θ̂) or, for a zero-mean GP, of the nominal indications.  ``n_alternations`` rounds.

Prediction: the compensated coordinate ``p(q; θ̂, t) − f̄(q, t)`` with standard uncertainty
``sqrt(u_kin² + var f)`` per component, ``var f`` the latent (noise-free) predictive variance
and ``u_kin`` from the covariance of θ̂ (the two treated as independent).

scikit-learn rather than GPyTorch: n ≈ 10³ training points make exact inference
(Cholesky, O(n³) ≈ 10⁹ flops) a fraction of a second on a CPU; scikit-learn gives exact
inference with analytic gradients of the marginal likelihood, is already a field-standard
dependency, and needs no torch runtime.

References
----------
Salacheep, P. (2016). *Error Compensation and Uncertainty Evaluation of CMMs Based on
Kinematic Error Models and Gaussian Processes*. MPhil thesis, Brunel University London,
Ch. 5.
Rasmussen, C. E., Williams, C. K. I. (2006). *Gaussian Processes for Machine Learning*.
MIT Press, eqs 2.25–2.26 (predictive mean and variance), 5.8 (marginal likelihood), §4.2
(Matérn class).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from threadpoolctl import threadpool_limits

from mtmetrology.cmm.calibrate import calibrate_ballplate
from mtmetrology.cmm.files import BallPlate, BallPlateRecords, ProbeSet
from mtmetrology.cmm.notebook import CMMNotebookRepr
from mtmetrology.cmm.problem import kabsch, skew
from mtmetrology.errors import InputError
from mtmetrology.io.files import InputFileError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.units import from_internal, to_internal

if TYPE_CHECKING:  # scikit-learn is imported when a model is fitted or read (0.5 s)
    from sklearn.gaussian_process import GaussianProcessRegressor

__all__ = ["KIND", "GPErrorModel", "fit_gp"]

KIND = "gp-error-model"
KERNELS = ("rbf", "matern")
COMPONENTS = "xyz"


def _kernel(kind: str):
    from sklearn.gaussian_process.kernels import RBF, ConstantKernel, Matern, WhiteKernel

    if kind not in KERNELS:
        raise InputError(f"kernel {kind!r}: use one of {', '.join(KERNELS)}")
    # isotropic length-scale on the readings (mm), as the source's covSEiso (§5.3)
    corr = RBF(500.0, (1.0, 1e6)) if kind == "rbf" else Matern(500.0, (1.0, 1e6), nu=2.5)
    # amplitude and noise in µm² (targets are in µm)
    return ConstantKernel(1.0, (1e-6, 1e4)) * corr + WhiteKernel(0.25, (1e-8, 1e2))


def _regressor(kernel, **options) -> GaussianProcessRegressor:
    from sklearn.gaussian_process import GaussianProcessRegressor

    return GaussianProcessRegressor(kernel, normalize_y=False, **options)


def _fit(gpr: GaussianProcessRegressor, x: np.ndarray, y: np.ndarray):
    from sklearn.exceptions import ConvergenceWarning

    # n ~ 10^3: one BLAS thread is fastest and avoids oversubscribing shared cores
    with threadpool_limits(1), warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        return gpr.fit(x, y)


@dataclass(frozen=True, eq=False)
class GPErrorModel(CMMNotebookRepr):
    """A fitted GP error model (see the module notes).

    Attributes
    ----------
    machine : Machine
        The CMM with the parameters of the kinematic mean active (none for zero mean).
    mean : ParameterSet or None
        The kinematic mean with its covariance.
    kernel : str
    regressors : tuple of GaussianProcessRegressor
        One per component x, y, z (targets in µm).
    inputs : ndarray (n, 3)
        Training inputs: axis readings, mm.
    targets_um : ndarray (n, 3)
    """

    machine: Machine
    mean: ParameterSet | None
    kernel: str
    regressors: tuple
    inputs: np.ndarray
    targets_um: np.ndarray
    provenance: dict

    def _theta(self):
        return None if self.mean is None else self.mean.values

    def predict(self, readings, tools, *, return_cov: bool = False):
        """Compensated stylus-centre coordinates and their standard uncertainty.

        Parameters
        ----------
        readings : ndarray (n, 3)
            Axis readings, mm.
        tools : ndarray (n, 3) or (3,)
            Stylus offsets, mm.
        return_cov : bool
            Also return the joint covariance (3, n, n) of the predicted points per
            component (mm²), for quantities of several points such as lengths.

        Returns
        -------
        points : ndarray (n, 3), mm
        u : ndarray (n, 3), mm
        cov : ndarray (3, n, n), mm² (only with ``return_cov``)
        """
        q = np.atleast_2d(np.asarray(readings, dtype=float))
        t = np.broadcast_to(np.asarray(tools, dtype=float), q.shape)
        x = q
        theta = self._theta()
        base = self.machine.forward(q, theta, tool=t)
        n = len(q)
        mean = np.empty((n, 3))
        cov = np.zeros((3, n, n))
        for c, gpr in enumerate(self.regressors):
            with threadpool_limits(1):
                m, k = gpr.predict(x, return_cov=True)
            # targets are not normalised, so the white-noise term on the diagonal of the
            # predictive covariance is noise_level itself (µm²): removing it leaves var f
            noise = gpr.kernel_.k2.noise_level
            mean[:, c] = m
            cov[c] = to_internal(to_internal(k - noise * np.eye(n), "µm"), "µm")
        if self.mean is not None and self.mean.covariance is not None:
            jac = self.machine.jacobian(q, theta, tool=t)  # (n, 3, p)
            for c in range(3):
                cov[c] += jac[:, c, :] @ self.mean.covariance @ jac[:, c, :].T
        points = base - to_internal(mean, "µm")
        u = np.sqrt(np.clip(np.diagonal(cov, axis1=1, axis2=2).T, 0.0, None))
        return (points, u, cov) if return_cov else (points, u)

    def to_document(self) -> dict:
        """The JSON model file (training data and fitted hyper-parameters)."""
        comps = []
        for c, gpr in zip(COMPONENTS, self.regressors, strict=True):
            k = gpr.kernel_
            comps.append(
                {
                    "component": c,
                    "log_hyperparameters": k.theta.tolist(),
                    "amplitude_um": float(np.sqrt(k.k1.k1.constant_value)),
                    "length_scale_mm": float(k.k1.k2.length_scale),
                    "noise_um": float(np.sqrt(k.k2.noise_level)),
                    "log_marginal_likelihood": float(gpr.log_marginal_likelihood_value_),
                }
            )
        return {
            "kind": KIND,
            "version": 1,
            "machine": self.machine.name,
            "kernel": self.kernel,
            "inputs": ["X_mm", "Y_mm", "Z_mm"],
            "mean": None if self.mean is None else self.mean.to_document(),
            "components": comps,
            "training": {"inputs_mm": self.inputs.tolist(), "targets_um": self.targets_um.tolist()},
            "provenance": self.provenance,
        }

    @classmethod
    def from_document(cls, doc: dict, base: Machine, source: str = "<gp model>") -> GPErrorModel:
        """Rebuild a model from its file: fitted hyper-parameters, no optimisation.

        Raises
        ------
        InputFileError
            Wrong kind, machine, or malformed content.
        """
        if not isinstance(doc, dict) or doc.get("kind") != KIND:
            raise InputFileError(f"{source}: kind: expected {KIND!r}")
        if doc.get("version") != 1:
            raise InputFileError(f"{source}: version: {doc.get('version')!r} is not supported")
        if doc.get("machine") != base.name:
            raise InputFileError(
                f"{source}: made for machine {doc.get('machine')!r}, not {base.name!r}"
            )
        try:
            kernel = str(doc["kernel"])
            x = np.asarray(doc["training"]["inputs_mm"], dtype=float)
            y = np.asarray(doc["training"]["targets_um"], dtype=float)
            thetas = [np.asarray(c["log_hyperparameters"], dtype=float) for c in doc["components"]]
        except (KeyError, TypeError, ValueError) as err:
            raise InputFileError(f"{source}: malformed GP model ({err})") from None
        if x.ndim != 2 or x.shape[1] != 3 or y.shape != (len(x), 3) or len(thetas) != 3:
            raise InputFileError(f"{source}: training data must be n x 3 inputs, n x 3 targets")
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
            raise InputFileError(f"{source}: training data holds non-finite values")
        machine, mean = base, None
        if doc.get("mean") is not None:
            mean = ParameterSet.from_document(doc["mean"], base, f"{source}: mean")
            machine = mean.machine_for(base)
        regs = []
        for c, th in enumerate(thetas):
            k = _kernel(kernel).clone_with_theta(th)
            gpr = _regressor(k, optimizer=None)
            regs.append(_fit(gpr, x, y[:, c]))
        return cls(machine, mean, kernel, tuple(regs), x, y, dict(doc.get("provenance") or {}))


def _targets(machine, theta, readings, tools, poses_r, poses_t, pos_idx, ball_xyz):
    pts = machine.forward(readings, theta, tool=tools)
    truth = np.einsum("nij,nj->ni", poses_r[pos_idx], ball_xyz) + poses_t[pos_idx]
    return pts, pts - truth


def fit_gp(
    base: Machine,
    records: BallPlateRecords,
    plate: BallPlate,
    probes: ProbeSet,
    *,
    sigma: float,
    mean: str | None = "seed",
    kernel: str = "rbf",
    n_alternations: int = 2,
    seed: int = 0,
) -> GPErrorModel:
    """Fit a GP error model to ball-plate records (alternating with the plate poses).

    Parameters
    ----------
    base : Machine
    records, plate, probes
        As for :func:`~mtmetrology.cmm.calibrate.calibrate_ballplate`.
    sigma : float
        Standard uncertainty of an indication coordinate, mm (for the kinematic mean).
    mean : str or None
        Kinematic mean model (``seed``, ``full-<d>``) or None for a zero-mean GP.
    kernel : {"rbf", "matern"}
    n_alternations : int
        Rounds of (GP fit, pose update) after the first fit.
    seed : int
        Random state of the optimiser.

    Returns
    -------
    GPErrorModel
    """
    tools = probes.offsets(records.probes)
    q = np.asarray(records.readings, dtype=float)
    if mean is not None:
        cal = calibrate_ballplate(base, records, plate, probes, model=mean, sigma=sigma)
        machine, pset = cal.machine, cal.parameters
        prob = cal.problem
        _, poses, balls = prob.split(cal.identification.estimate)
        rot = np.einsum("lij,ljk->lik", np.eye(3) + skew(poses[:, :3]), prob.rotations0)
        trans = poses[:, 3:].copy()
        pos_ids, ball_ids = prob.position_ids, prob.ball_ids
    else:
        machine, pset = base.with_parameters([]), None
        pos_ids = records.position_ids
        ball_ids = tuple(b for b in plate.ids if b in set(records.balls))
        balls = plate.coordinates[[plate.ids.index(b) for b in ball_ids]]
        rot, trans = np.empty((len(pos_ids), 3, 3)), np.empty((len(pos_ids), 3))
    pos_idx = np.array([pos_ids.index(p) for p in records.positions])
    ball_idx = np.array([ball_ids.index(b) for b in records.balls])
    theta = None if pset is None else pset.values
    if mean is None:  # poses of the nominal indications
        pts = machine.forward(q, None, tool=tools)
        for k in range(len(pos_ids)):
            s = pos_idx == k
            rot[k], trans[k] = kabsch(balls[ball_idx[s]], pts[s])
    x = q
    regs = [None, None, None]
    kern = [_kernel(kernel)] * 3
    for it in range(n_alternations + 1):
        pts, d = _targets(machine, theta, q, tools, rot, trans, pos_idx, balls[ball_idx])
        y = from_internal(d, "µm")
        for c in range(3):
            gpr = _regressor(kern[c], random_state=seed)
            regs[c] = _fit(gpr, x, y[:, c])
            kern[c] = regs[c].kernel_  # warm start of the next round
        if it == n_alternations:
            break
        with threadpool_limits(1):
            fhat = np.column_stack([r.predict(x) for r in regs])
        comp = pts - to_internal(fhat, "µm")
        for k in range(len(pos_ids)):
            s = pos_idx == k
            rot[k], trans[k] = kabsch(balls[ball_idx[s]], comp[s])
    prov = {
        "method": "GP per error component, alternating with plate poses",
        "mean": mean or "zero",
        "alternations": n_alternations,
        "sigma_um": from_internal(sigma, "µm"),
    }
    return GPErrorModel(machine, pset, kernel, tuple(regs), x, y, prov)
