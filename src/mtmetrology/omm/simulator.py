"""Covariance simulator of the full-covariance method: the inputs x = [Γ; Δ; E] and U_x.

The on-machine measurement function of Sepahi Boroujeni (2021), §6.2, maps the
long-term axis positions Γ_s of the n probed points, the machine parameters Δ and the
unexplained volumetric errors e_s to the compensated points

    q_s = f(Γ_s, Δ) + e_s                                                     (eq. 6-14)

and a feature g(q).  Its input covariance U_x comes from the covariance simulator
(§6.2.2, Populations I–IV):

    I    Φ_s ~ N(φ_s, v_s)               short-term readings (repeatability model, eq. 6-2)
    II   Ψ_s = f(Φ_s, δ)                  the physical point on the fixed workpiece (6-3)
    III  Δ ~ N(δ, Σ)                      long-term parameters (6-4)
    IV   Γ_s = f⁻¹(Ψ_s; Δ)                the readings that machine would need (6-7)

with the rotary readings of Γ held at their commanded values, and [Γ; Δ] pooled into
one sample whose covariance is U_x.  E is independent of both: its block is
I_n ⊗ cov(e) (eqs. 6-13 to 6-15).

Two ways to build U_x are offered:

``"linear"`` (default)
    Population IV linearised about (φ, δ):
    Γ_s − φ_s = L F_s⁻¹ [A_s (Φ_s − φ_s) − G_s (Δ − δ)], with A_s = ∂f/∂q, G_s = ∂f/∂δ and
    F_s the linear-axis columns of A_s, so U_x is exact for the linearised model and has
    no sampling noise.
``"sampled"``
    The thesis' algorithm as printed (Q draws of Populations I–IV through the kinematic
    model and its inverse; Q = 10⁴ in the thesis), with the sample covariance as U_x.

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, §6.2 and Appendix A.3.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import block_diag

from mtmetrology.errors import InputError
from mtmetrology.kinematics.chain import ChainEvaluation
from mtmetrology.kinematics.machine import Machine
from mtmetrology.rng import SeedLike, as_generator
from mtmetrology.uncertainty.distributions import MultivariateNormal
from mtmetrology.uncertainty.inputs import InputSet
from mtmetrology.units import internal_unit

__all__ = ["SIMULATORS", "MeasurementModel", "TaskInputs", "covariance_simulator"]

SIMULATORS = ("linear", "sampled")


@dataclass(frozen=True)
class TaskInputs:
    """Inputs x = [Γ (n × n_axes); Δ (P); E (3n)] of a task with their covariance U_x.

    It is what the GUF engine reads (names, units, estimate, covariance, dof); Monte Carlo
    samples :meth:`input_set`, whose factorisation of U_x the GUF does not need.

    Attributes
    ----------
    names, units : tuple of str, length N = n·n_axes + P + 3n
        ``X_1, Y_1, ..., C_n`` (mm, rad), the parameter names (internal units of their
        customary ones: mm, rad, mm/mm for µm/m ...), ``ex_1 ... ez_n`` (mm).
    estimate : (N,) ndarray
        x = [φ; δ; 0].
    covariance : (N, N) ndarray
        U_x (PSD, exactly symmetric).
    n_points, n_axes, n_params : int
    simulator : {"linear", "sampled"}
    draws : int or None
        Q of the sampled simulator.
    at_estimate : ChainEvaluation
        The kinematic model at x: the compensated points f(φ_s, δ) (``position``, (n, 3))
        with ∂f/∂q (``d_axes``) and ∂f/∂δ (``d_params``), which the GUF reuses.
    """

    names: tuple[str, ...]
    units: tuple[str, ...]
    estimate: np.ndarray
    covariance: np.ndarray
    n_points: int
    n_axes: int
    n_params: int
    simulator: str
    draws: int | None
    at_estimate: ChainEvaluation = field(repr=False)

    @property
    def groups(self) -> dict[str, slice]:
        """Slices of x: repeatability-driven Γ, machine parameters Δ, unexplained E."""
        a = self.n_points * self.n_axes
        b = a + self.n_params
        return {
            "repeatability": slice(0, a),
            "machine_parameters": slice(a, b),
            "unexplained_volumetric_error": slice(b, b + 3 * self.n_points),
        }

    @property
    def dof(self) -> np.ndarray:
        """Degrees of freedom of the inputs: infinite (the covariances are taken as known)."""
        return np.full(len(self.names), np.inf)

    def input_set(self) -> InputSet:
        """The inputs as jointly normal quantities (for the GUF and Monte Carlo engines)."""
        return InputSet.from_covariance(self.names, self.estimate, self.covariance, self.units)


@dataclass(frozen=True)
class MeasurementModel:
    """x ↦ g(f(Γ, Δ) + E), vectorised over leading trial axes (Sepahi Boroujeni (2021),
    Appendix A.4).  A module-level class, so process executors can pickle it."""

    machine: Machine
    feature: object
    n_points: int
    senses: np.ndarray | None = None

    @property
    def output_names(self) -> tuple[str, ...]:
        return tuple(self.feature.output_names)

    @property
    def output_units(self) -> tuple[str, ...]:
        return (self.feature.unit,) * len(self.output_names)

    def points(self, x: np.ndarray) -> np.ndarray:
        """Compensated points q (..., n, 3) of inputs x (..., N)."""
        n, n_axes, n_par = self.n_points, self.machine.n_axes, self.machine.n_params
        lead = x.shape[:-1]
        gamma = x[..., : n * n_axes].reshape(*lead, n, n_axes)
        delta = x[..., n * n_axes : n * n_axes + n_par]
        q = self.machine.forward(gamma, delta[..., None, :], senses=self.senses)
        return q + x[..., n * n_axes + n_par :].reshape(*lead, n, 3)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        return self.feature.value(self.points(np.asarray(x, float)))


def covariance_simulator(
    machine: Machine,
    readings: np.ndarray,
    parameters: np.ndarray,
    parameter_covariance: np.ndarray,
    *,
    reading_covariance: np.ndarray | None = None,
    unexplained_covariance: np.ndarray | None = None,
    senses: np.ndarray | None = None,
    simulator: str = "linear",
    draws: int = 10_000,
    seed: SeedLike = None,
) -> TaskInputs:
    """x = [φ; δ; 0] and U_x of the full-covariance method (Populations I–IV).

    Parameters
    ----------
    machine : Machine
        With exactly three linear axes (Population IV solves for them).
    readings : (n, n_axes) array
        Probed readings φ_s (mm, rad).
    parameters : (P,) array
        Machine parameters δ (internal units, ``machine.parameter_names`` order).
    parameter_covariance : (P, P) array
        Long-term covariance Σ of the parameters.
    reading_covariance : (n, n_axes, n_axes) array, optional
        v_s of each reading (zero rotary rows); none means perfect repeatability.
    unexplained_covariance : (3, 3) array, optional
        cov(e), mm² (PSD).
    senses : (n, n_axes) array, optional
        Sense of motion per axis.
    simulator : {"linear", "sampled"}
        Linearised Population IV (exact for the linearised model, no sampling noise) or
        the thesis' Q-draw sample covariance (Appendix A.3).
    draws : int
        Q of the sampled simulator (Sepahi Boroujeni (2021): 10⁴).
    seed : int, SeedSequence or Generator, optional
        Randomness of the sampled simulator.

    Returns
    -------
    TaskInputs

    Raises
    ------
    InputError
        Shapes that do not match the machine, a machine without three linear axes, a
        singular linear-axis Jacobian, a covariance that is not positive semidefinite, an
        unknown simulator or too few draws.

    Notes
    -----
    To first order, A_s (Γ_s − φ_s) + G_s (Δ − δ) = A_s (Φ_s − φ_s): the machine-parameter
    uncertainty cancels from the compensated points whatever Σ is (Sepahi Boroujeni (2021),
    §6.2; the thesis' 1-D example, eqs. 6-8 to 6-12, shows the correlation that does it:
    corr(Γ, Δ) = −0.71).  The parameters enter the *value* (the compensation), and only
    the second-order terms, which Monte Carlo sees, of its uncertainty.
    The thesis' 1-D example (eqs. 6-8 to 6-12: φ = 100 mm, v = 1 µm², a scale error of
    −50 µm/m with σ = 100 (µm/m)², giving var Γ = 2.0 µm² and cov(Γ, Δ) = −10⁻² mm·µm/m)
    is reproduced by both simulators in ``tests/omm/test_simulator.py``.
    """
    if simulator not in SIMULATORS:
        raise InputError(f"simulator must be one of {', '.join(SIMULATORS)}, got {simulator!r}")
    q = np.asarray(readings, float)
    if q.ndim != 2 or q.shape[1] != machine.n_axes:
        raise InputError(
            f"readings must have shape (n, {machine.n_axes}) for machine {machine.name}, "
            f"got {q.shape}"
        )
    n, n_axes = q.shape
    n_par = machine.n_params
    delta = np.asarray(parameters, float)
    if delta.shape != (n_par,) or not np.all(np.isfinite(delta)):
        raise InputError(f"parameters: expected {n_par} finite values, got shape {delta.shape}")
    sigma = check_psd(parameter_covariance, (n_par, n_par), "parameter covariance")
    v = (
        np.zeros((n, n_axes, n_axes))
        if reading_covariance is None
        else check_psd(reading_covariance, (n, n_axes, n_axes), "reading covariance")
    )
    cov_e = (
        np.zeros((3, 3))
        if unexplained_covariance is None
        else check_psd(unexplained_covariance, (3, 3), "unexplained volumetric error covariance")
    )
    linear = [machine.axis_names.index(x) for x in machine.linear_axes]
    if len(linear) != 3:
        raise InputError(f"machine {machine.name}: the task model needs three linear axes")
    ev = machine.evaluate(q, delta, senses=senses, d_params=True, d_axes=True)
    if np.any(np.abs(np.linalg.det(ev.d_axes[:, :, linear])) < 1e-12):
        raise InputError("the linear axes do not span space at a probed pose (singular ∂f/∂q)")
    size = n * n_axes + n_par + 3 * n
    ux = np.zeros((size, size))
    if simulator == "linear":
        ux[: n * n_axes + n_par, : n * n_axes + n_par] = _linear_population_covariance(
            ev, sigma, v, linear
        )
    else:
        if int(draws) < 2 * size:
            raise InputError(
                f"draws: the sampled simulator needs at least 2·N = {2 * size} draws for "
                f"{size} inputs, got {draws}"
            )
        ux[: n * n_axes + n_par, : n * n_axes + n_par] = _sampled_population_covariance(
            machine, q, delta, sigma, v, senses, linear, int(draws), seed
        )
    e0 = n * n_axes + n_par
    ux[e0:, e0:] = np.kron(np.eye(n), cov_e)
    names = [f"{ax}_{s + 1}" for s in range(n) for ax in machine.axis_names]
    names += list(machine.parameter_names) + [f"e{c}_{s + 1}" for s in range(n) for c in "xyz"]
    units = [("mm" if ax in machine.linear_axes else "rad") for ax in machine.axis_names] * n
    units += [internal_unit(u) for u in machine.parameter_units] + ["mm"] * (3 * n)
    return TaskInputs(
        tuple(names),
        tuple(units),
        np.concatenate([q.ravel(), delta, np.zeros(3 * n)]),
        0.5 * (ux + ux.T),
        n,
        n_axes,
        n_par,
        simulator,
        int(draws) if simulator == "sampled" else None,
        ev,
    )


def _linear_population_covariance(ev, sigma, v, linear) -> np.ndarray:
    """Cov [Γ; Δ] of the linearised Population IV, from the model's Jacobians at x."""
    a, g = ev.d_axes, ev.d_params  # (n, 3, n_axes), (n, 3, P)
    n, _, n_axes = a.shape
    n_par = g.shape[-1]
    f_inv = np.linalg.inv(a[:, :, linear])
    m_stack = (-f_inv @ g).reshape(3 * n, n_par)  # ∂Γ_lin/∂Δ of every point, stacked
    gamma_cov = m_stack @ sigma @ m_stack.T  # parameter-driven part, all point pairs
    own = f_inv @ (a @ v @ np.swapaxes(a, 1, 2)) @ np.swapaxes(f_inv, 1, 2)  # repeatability
    idx = np.arange(n)[:, None, None] * 3
    rows = idx + np.arange(3)[None, :, None]
    cols = idx + np.arange(3)[None, None, :]
    gamma_cov[rows, cols] += own
    lin = (np.arange(n)[:, None] * n_axes + np.array(linear)[None, :]).ravel()  # (3n,)
    out = np.zeros((n * n_axes + n_par, n * n_axes + n_par))
    par = slice(n * n_axes, n * n_axes + n_par)
    out[np.ix_(lin, lin)] = gamma_cov
    cross = m_stack @ sigma
    out[lin, par] = cross
    out[par, lin] = cross.T
    out[par, par] = sigma
    return out


def _sampled_population_covariance(machine, q, delta, sigma, v, senses, linear, draws, seed):
    """Sample cov [Γ; Δ] of Q draws of Populations I–IV (Appendix A.3)."""
    rng = as_generator(seed)
    n, n_axes = q.shape
    # I: the readings of all points, independent between points (block-diagonal v).
    phi = MultivariateNormal(q.ravel(), block_diag(*v)).sample(rng, draws).reshape(draws, n, n_axes)
    psi = machine.forward(phi, delta, senses=senses)  # II
    deltas = MultivariateNormal(delta, sigma).sample(rng, draws)  # III
    # IV: rotary readings stay commanded; one member of II per member of III (§6.2.2).
    gamma = machine.inverse(psi, np.broadcast_to(q, phi.shape), deltas[:, None, :], senses=senses)
    # Only the linear readings and Δ vary: the rotary ones are constants, exactly.
    lin = (np.arange(n)[:, None] * n_axes + np.array(linear)[None, :]).ravel()
    live = np.concatenate([lin, n * n_axes + np.arange(machine.n_params)])
    out = np.zeros((n * n_axes + machine.n_params,) * 2)
    pop = np.hstack([gamma.reshape(draws, -1)[:, lin], deltas])
    out[np.ix_(live, live)] = np.cov(pop, rowvar=False)
    return out


def check_psd(matrix, shape: tuple[int, ...], what: str) -> np.ndarray:
    """A finite, symmetric, positive semidefinite (stack of) covariance matrix, or InputError."""
    m = np.asarray(matrix, float)
    if m.shape != shape or not np.all(np.isfinite(m)):
        raise InputError(f"{what}: expected finite values of shape {shape}, got {m.shape}")
    if not np.allclose(m, np.swapaxes(m, -1, -2), rtol=1e-10, atol=0):
        raise InputError(f"{what}: not symmetric")
    low = np.linalg.eigvalsh(m).min(axis=-1)
    scale = np.abs(m).max(axis=(-1, -2))
    if np.any(low < -1e-10 * np.maximum(scale, np.finfo(float).tiny)):
        raise InputError(
            f"{what}: not positive semidefinite (smallest eigenvalue {float(np.min(low)):.3g})"
        )
    return m
