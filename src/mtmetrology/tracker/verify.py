"""Monte Carlo of a whole tracker verification (Aguado et al. (2019), Section 3, Study 2).

Measurement model of one simulated verification k (GUM Supplement 1 propagation; every
input drawn independently per verification):

- true error parameters ``θ + δθ_k`` (random parts, eqs 18–20, normal or Beta);
- axis positions ``q_eff`` (reversal, repeatability, thermal expansion with a CTE drawn
  with u(α) of eq. 10), recorded temperatures with the sensor error (eq. 3);
- the true tracker pose perturbed on the rotation group about the nominal one
  (eqs 25–26 as a set-up scatter, :func:`~mtmetrology.kinematics.tracker.perturb_pose`);
- tracker readings with the noise of A3.2 (level N(20, 3) µrad drawn per test) and SMR;
- identification of the datum's error parameters and the pose from those readings,
  weighted as :func:`~mtmetrology.tracker.calibrate` weights them;
- compensation: the *final error* of a point is the identified model's tool position less
  the true one, both seen by the tracker (so the frame is the one the verification
  defines); the *initial error* is the measured position less the nominal (eq. 1).

Per verification the mean final volumetric error is eq. 27 over the mesh.

Batched identification.  The machine model is linear in θ about zero (its second-order
terms, products of angular errors and error displacements, are reported as
``linearisation_error``: about 0.01 µm for errors of 20 µm and µrad); the pose enters
exactly.
All K identifications run at once on the one least-squares core
(:func:`mtmetrology.optimize.chord_batch`: each trial starts from the nominal solution and
reuses its factorised Jacobian; the pose perturbations of ~1 mrad make the chord converge
in 3–4 steps).

Coverage: the predicted standard uncertainty of a compensated position at a held-out point
(cell centres of the mesh) is ``√diag(G C Gᵀ)``, C the covariance of the identification, G
the model's sensitivity there; :attr:`TrackerVerification.coverage` counts, over
verifications, how often ``|e| ≤ 1.96·u`` holds for one component of one held-out point
per verification (chosen cyclically, so the K Bernoulli trials are independent).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from mtmetrology._memory import require_memory
from mtmetrology.errors import InputError, ResourceLimitError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.tracker import (
    TrackerLimits,
    TrackerNoise,
    TrackerPose,
    cartesian,
    euler_matrix,
    perturb_pose,
    spherical,
)
from mtmetrology.optimize import chord_batch
from mtmetrology.rng import SeedLike, as_generator
from mtmetrology.tracker.calibrate import corrected_readings, point_covariances
from mtmetrology.tracker.model import datum, setup_terms, tracker_points, whitening
from mtmetrology.tracker.setup import MachineConditions, check_pose, measurement_points
from mtmetrology.tracker.simulate import effective_readings, geometric_draws
from mtmetrology.units import from_internal, to_internal

__all__ = ["TrackerVerification", "verify"]

_CHUNK = 1000
#: Verifications whose full per-point final errors are kept (histograms).
_KEEP = 200
#: Most verifications one run simulates: JCGM 101:2008's 10⁶ trials (7.9.1, enough for a
#: 95 % interval to two significant digits); each is a complete identification (about
#: 4 ms on one core), so 10⁶ already takes an hour.
MAX_TRIALS = 1_000_000
#: Bytes kept per verification: mean initial, mean final and maximum final error (float64)
#: and the held-out coverage flag.
_BYTES_PER_TRIAL = 3 * 8 + 1


@dataclass(frozen=True, eq=False)
class TrackerVerification:
    """Result of :func:`verify` (lengths in mm).

    Attributes
    ----------
    mesh : (n, 3) ndarray
        Commanded points (each with its tool offset, ``tools``).
    tools : (n, 3) ndarray
    kept, dropped : tuple of str
        The datum identified in every verification (with the constants the set-up
        exposes, :func:`~mtmetrology.tracker.model.setup_terms`) and the parameters it
        cannot see.
    mean_initial, mean_final : (K,) ndarray
        Eq. 27 per verification: mean |initial error| and mean |final error| over the mesh.
    max_final : (K,) ndarray
        Largest |final error| of each verification.
    final_errors : (min(K, 200), n, 3) ndarray
        Final errors of the first verifications (histograms).
    point_initial : (n,) ndarray
        Per mesh point: mean |initial error| over the verifications.
    point_mean, point_max : (n,) ndarray
        Per mesh point: mean and largest |final error| over the verifications.
    point_uncertainty : (n,) ndarray
        Predicted standard uncertainty ``√tr(G C Gᵀ)`` of the compensated position.
    coverage : dict
        Held-out coverage count, trials, rate and its binomial acceptance region.
    linearisation_error : float
        Largest difference between the linear-in-θ model and the exact chain at the truth.
    status_message : str
        Of the batched identifications.
    provenance : dict
    """

    mesh: np.ndarray
    tools: np.ndarray
    kept: tuple[str, ...]
    dropped: tuple[str, ...]
    mean_initial: np.ndarray
    mean_final: np.ndarray
    max_final: np.ndarray
    final_errors: np.ndarray = field(repr=False)
    point_initial: np.ndarray = field(repr=False)
    point_mean: np.ndarray = field(repr=False)
    point_max: np.ndarray = field(repr=False)
    point_uncertainty: np.ndarray = field(repr=False)
    coverage: dict = field(default_factory=dict)
    linearisation_error: float = 0.0
    status_message: str = ""
    provenance: dict = field(default_factory=dict)

    @property
    def trials(self) -> int:
        return int(self.mean_final.size)

    def statistics(self) -> dict:
        """Mean, σ, mean + 2σ (k = 2, the paper's 95 % figure) of the mean final volumetric
        error, the largest final error, and the initial mean, all in µm."""
        um = from_internal(1.0, "µm")
        m, s = float(self.mean_final.mean()), float(self.mean_final.std(ddof=1))
        return {
            "mean_final_um": m * um,
            "sigma_final_um": s * um,
            "mean_plus_2sigma_um": (m + 2 * s) * um,
            "max_final_um": float(self.max_final.max()) * um,
            "mean_initial_um": float(self.mean_initial.mean()) * um,
        }

    def distribution_fits(self) -> list[dict]:
        """Normal, lognormal and gamma fits of the mean final error, with the
        Kolmogorov–Smirnov p-value (parameters estimated from the same data, so the
        p-values are optimistic: a small one rejects, a large one does not confirm)."""
        x = self.mean_final * from_internal(1.0, "µm")
        out = []
        for name, dist in (("normal", stats.norm), ("lognormal", stats.lognorm),
                           ("gamma", stats.gamma)):  # fmt: skip
            params = dist.fit(x)
            p = stats.kstest(x, dist(*params).cdf).pvalue
            out.append({"distribution": name, "parameters": list(map(float, params)),
                        "ks_pvalue": float(p)})  # fmt: skip
        return out

    def summary(self) -> str:
        s = self.statistics()
        c = self.coverage
        return "\n".join(
            [
                f"tracker verification Monte Carlo: {self.trials} verifications of "
                f"{len(self.mesh)} points ({self.status_message})",
                f"  mean final volumetric error {s['mean_final_um']:.2f} µm, σ "
                f"{s['sigma_final_um']:.2f} µm, mean + 2σ {s['mean_plus_2sigma_um']:.2f} µm",
                f"  largest final error {s['max_final_um']:.1f} µm; mean initial error "
                f"{s['mean_initial_um']:.1f} µm",
                f"  held-out coverage of ±1.96 u: {c['rate']:.3f} ({c['covered']}/{c['trials']}; "
                f"binomial 99.7 % region for 95 %: {c['region'][0]:.3f}–{c['region'][1]:.3f})",
                f"  not identified: {', '.join(self.dropped) or 'none'}",
            ]
        )

    def to_dict(self) -> dict:
        um = from_internal(1.0, "µm")
        return {
            "kind": "tracker-verification",
            "version": 1,
            "mesh_mm": self.mesh.tolist(),
            "tools_mm": self.tools.tolist(),
            "kept": list(self.kept),
            "dropped": list(self.dropped),
            "statistics": self.statistics(),
            "distribution_fits": self.distribution_fits(),
            "mean_initial_um": (self.mean_initial * um).tolist(),
            "mean_final_um": (self.mean_final * um).tolist(),
            "max_final_um": (self.max_final * um).tolist(),
            "final_errors_um": (self.final_errors * um).tolist(),
            "point_initial_um": (self.point_initial * um).tolist(),
            "point_mean_um": (self.point_mean * um).tolist(),
            "point_max_um": (self.point_max * um).tolist(),
            "point_uncertainty_um": (self.point_uncertainty * um).tolist(),
            "coverage": self.coverage,
            "linearisation_error_um": self.linearisation_error * um,
            "status_message": self.status_message,
            "provenance": self.provenance,
        }

    @classmethod
    def from_dict(cls, doc: dict) -> TrackerVerification:
        mm = to_internal(1.0, "µm")

        def arr(key):
            return np.asarray(doc[key], dtype=float) * mm

        return cls(
            np.asarray(doc["mesh_mm"], float),
            np.asarray(doc["tools_mm"], float),
            tuple(doc["kept"]),
            tuple(doc["dropped"]),
            arr("mean_initial_um"),
            arr("mean_final_um"),
            arr("max_final_um"),
            arr("final_errors_um"),
            arr("point_initial_um"),
            arr("point_mean_um"),
            arr("point_max_um"),
            arr("point_uncertainty_um"),
            dict(doc["coverage"]),
            doc["linearisation_error_um"] * mm,
            doc["status_message"],
            dict(doc["provenance"]),
        )


def _held_out(mesh: np.ndarray) -> np.ndarray:
    """Cell centres of the mesh in X and Y, at its Z levels."""
    xs, ys, zs = (np.unique(mesh[:, i]) for i in range(3))
    cx, cy = (xs[:-1] + xs[1:]) / 2, (ys[:-1] + ys[1:]) / 2
    if cx.size == 0 or cy.size == 0:
        raise InputError("--mesh: need at least two X and two Y levels for held-out points")
    g = np.meshgrid(cx, cy, zs, indexing="ij")
    return np.stack([a.ravel() for a in g], axis=1)


def verify(
    machine: Machine,
    truth: np.ndarray,
    pose: TrackerPose,
    mesh: np.ndarray,
    tools: np.ndarray,
    *,
    trials: int = 1000,
    noise: TrackerNoise | None = None,
    conditions: MachineConditions | None = None,
    limits: TrackerLimits | None = None,
    pose_scatter: tuple[float, float] = (1.0, 1e-3),
    seed: SeedLike = None,
    progress=None,
) -> TrackerVerification:
    """Monte Carlo of ``trials`` complete verifications (module notes).

    Parameters
    ----------
    machine : Machine
        The machine with its candidate error model.
    truth : (n_params,) ndarray
        True error parameters (internal units).
    pose : TrackerPose
        Nominal tracker pose.
    mesh, tools : ndarray
        Commanded mesh points and tool offsets, mm.
    trials : int
        Number of simulated verifications (≥ 10).
    noise, conditions, limits
        Tracker noise, machine conditions, tracker limits (defaults of the paper).
    pose_scatter : (float, float)
        Standard deviations of the true pose about the nominal one between verifications:
        position (mm) and rotation (rad).
    seed : int, optional
    progress : callable, optional
        ``progress(done, trials)`` after each chunk of verifications, for a progress
        display; the result does not depend on it.

    Returns
    -------
    TrackerVerification

    Raises
    ------
    InputError
        Fewer than 10 trials, a truth of the wrong size, a pose the limits refuse.
    ResourceLimitError
        More than :data:`MAX_TRIALS` trials, or more than the memory holds (checked before
        any work).
    """
    if not isinstance(trials, int | np.integer) or trials < 10:
        raise InputError(f"--trials must be an integer >= 10, got {trials}")
    if trials > MAX_TRIALS:
        raise ResourceLimitError(
            f"--trials {trials}: at most {MAX_TRIALS} verifications (JCGM 101's 10⁶ trials; "
            f"each is a complete identification, about 4 ms: {trials} would take about "
            f"{trials * 4e-3 / 3600:.3g} h)"
        )
    require_memory(
        trials * _BYTES_PER_TRIAL,
        f"--trials {trials}: {_BYTES_PER_TRIAL} bytes kept per verification",
    )
    noise = noise or TrackerNoise()
    conditions = conditions or MachineConditions()
    limits = limits or TrackerLimits()
    theta = np.asarray(truth, dtype=float)
    if theta.shape != (machine.n_params,) or not np.all(np.isfinite(theta)):
        raise InputError(f"truth: need {machine.n_params} finite parameters of {machine.name}")
    q, t = measurement_points(mesh, tools)
    nominal = machine.forward(q, tool=t)
    check_pose(pose, machine, nominal, limits)
    chosen = datum(machine, q, t, pose)
    # the constants the set-up exposes are identified, as by calibrate (zero in the truth)
    added = setup_terms(machine, chosen, q, t, pose).added
    if added:
        machine = machine.with_parameters([*machine.parameter_names, *added])
        theta = np.concatenate([theta, np.zeros(len(added))])
    identified = (*chosen.kept, *added)
    keep = [machine.parameter_names.index(n) for n in identified]
    n_id = len(keep)

    # truth and nominal sensitivities, once
    ev = machine.evaluate(q, theta, tool=t, d_params=True, d_axes=True)
    lin_error = float(np.abs(nominal + ev.d_params @ theta - ev.position).max())
    ev0 = machine.evaluate(q, tool=t, d_params=True, d_axes=True)
    j_theta = ev0.d_params[..., keep]  # (n, 3, n_id)
    weights = whitening(
        point_covariances(
            machine, q, t, conditions.temperatures(machine, q), pose.to_tracker(nominal),
            pose, noise, conditions,
        )
    )  # fmt: skip
    x0 = np.concatenate([np.zeros(n_id), pose.vector])

    def model(x: np.ndarray, offsets: np.ndarray) -> np.ndarray:
        """Predicted tracker points (k, n, 3): nominal + J_θ θ + ∂f/∂q (q' − q), posed."""
        machine_pts = nominal + np.einsum("nik,bk->bni", j_theta, x[:, :n_id]) + offsets
        return tracker_points(machine_pts, x[:, n_id:])

    g0 = np.concatenate(
        [np.einsum("ji,njk->nik", pose.rotation, j_theta), pose.jacobian(nominal)], axis=-1
    )  # (n, 3, n_id + 6)
    jac0 = np.einsum("nij,njk->nik", weights, g0).reshape(-1, n_id + 6)
    _, s, vt = np.linalg.svd(jac0, full_matrices=False)
    covariance = (vt.T / s**2) @ vt

    held = _held_out(mesh)
    held_t = np.broadcast_to(t[0], held.shape)
    evh = machine.evaluate(held, theta, tool=held_t, d_params=True, d_axes=True)
    evh0 = machine.evaluate(held, tool=held_t, d_params=True)
    gh = np.concatenate(
        [np.einsum("ji,njk->nik", pose.rotation, evh0.d_params[..., keep]),
         pose.jacobian(evh0.position)], axis=-1,
    )  # fmt: skip
    u_held = np.sqrt(np.einsum("nik,kl,nil->ni", gh, covariance, gh))  # (h, 3) tracker frame

    rng = as_generator(seed)
    out = {k: [] for k in ("mi", "mf", "xf", "cov")}
    point_sum = np.zeros(len(q))
    point_initial = np.zeros(len(q))
    point_max = np.zeros(len(q))
    kept_errors = []
    messages = []
    done = 0
    while done < trials:
        k = min(_CHUNK, trials - done)
        d_theta = geometric_draws(rng, theta, conditions, k)
        q_eff, t_rec = effective_readings(rng, machine, q, conditions, k)
        true_m = ev.position + np.einsum("nij,bnj->bni", ev.d_axes, q_eff - q)
        true_m += np.einsum("nij,bj->bni", ev.d_params, d_theta)
        poses = perturb_pose(pose, rng, pose_scatter[0], pose_scatter[1], k)
        true_lt = tracker_points(true_m, poses)
        read = noise.sample_readings(rng, spherical(true_lt))
        measured = cartesian(read) + noise.sample_smr(rng, read.shape[:-1])
        offsets = np.einsum(
            "nij,bnj->bni", ev0.d_axes, corrected_readings(q, t_rec, conditions) - q
        )

        def residuals(x, idx, offsets=offsets, measured=measured):
            r = model(x, offsets[idx]) - measured[idx]
            return np.einsum("nij,bnj->bni", weights, r).reshape(len(idx), -1)

        start = np.tile(x0, (k, 1))
        start[:, n_id:] = poses  # a registration lands near the true pose
        sol = chord_batch(residuals, start, jac0, xtol=1e-6, max_iter=30, apply_final_step=True)
        messages.append(sol.message)
        pred = model(sol.x, offsets)
        rot = _rot(poses)  # tracker → machine: p = R p_LT + T
        final = np.einsum("bij,bnj->bni", rot, pred - true_lt)
        initial = np.einsum("bij,bnj->bni", rot, measured) + poses[:, None, :3] - nominal
        nf = np.linalg.norm(final, axis=-1)
        ni = np.linalg.norm(initial, axis=-1)
        point_initial += ni.sum(axis=0)
        out["mi"].append(ni.mean(axis=1))
        out["mf"].append(nf.mean(axis=1))
        out["xf"].append(nf.max(axis=1))
        point_sum += nf.sum(axis=0)
        point_max = np.maximum(point_max, nf.max(axis=0))
        if done < _KEEP:
            kept_errors.append(final[: _KEEP - done])
        # held-out coverage: one component of one held-out point per verification
        trial_ids = done + np.arange(k)
        h = trial_ids % len(held)
        comp = (trial_ids // len(held)) % 3
        true_h = evh.position[h] + np.einsum("bij,bj->bi", evh.d_params[h], d_theta)
        true_h_lt = np.einsum("bi,bij->bj", true_h - poses[:, :3], _rot(poses))
        pred_h_m = evh0.position[h] + np.einsum("bik,bk->bi", evh0.d_params[h][..., keep],
                                               sol.x[:, :n_id])  # fmt: skip
        pose_hat = sol.x[:, n_id:]
        pred_h_lt = np.einsum("bi,bij->bj", pred_h_m - pose_hat[:, :3], _rot(pose_hat))
        e = (pred_h_lt - true_h_lt)[np.arange(k), comp]
        out["cov"].append(np.abs(e) <= 1.96 * u_held[h, comp])
        done += k
        if progress is not None:
            progress(done, trials)
    covered = np.concatenate(out["cov"])
    n_cov = covered.size
    half = 3.0 * np.sqrt(0.95 * 0.05 / n_cov)
    return TrackerVerification(
        mesh=q,
        tools=t,
        kept=identified,
        dropped=chosen.dropped_names,
        mean_initial=np.concatenate(out["mi"]),
        mean_final=np.concatenate(out["mf"]),
        max_final=np.concatenate(out["xf"]),
        final_errors=np.concatenate(kept_errors),
        point_initial=point_initial / trials,
        point_mean=point_sum / trials,
        point_max=point_max,
        point_uncertainty=np.sqrt(np.einsum("nik,kl,nil->n", g0, covariance, g0)),
        coverage={
            "covered": int(covered.sum()),
            "trials": int(n_cov),
            "rate": float(covered.mean()),
            "region": [0.95 - half, 0.95 + half],
        },
        linearisation_error=lin_error,
        status_message="; ".join(sorted(set(messages))),
        provenance={
            "machine": machine.name,
            "pose": pose.to_dict(),
            "noise": noise.to_dict(),
            "conditions": conditions.to_dict(),
            "trials": int(trials),
            "seed": seed if isinstance(seed, int) else None,
        },
    )


def _rot(x: np.ndarray) -> np.ndarray:
    """Rotations (k, 3, 3) of pose vectors (k, 6)."""
    return euler_matrix(x[:, 3], x[:, 4], x[:, 5])
