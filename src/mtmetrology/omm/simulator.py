"""Inputs x = [Γ; Δ; E] of an on-machine task and their covariance U_x, by source.

The on-machine measurement function of Sepahi Boroujeni (2021), §6.2, maps the axis
readings Γ_s of the n probed points, the machine parameters Δ used for the compensation and
the unexplained volumetric errors e_s to the compensated points

    q_s = f(Γ_s, Δ) + e_s                                                     (eq. 6-14)

and a feature g(q).  What a real measurement compensates with is the calibration's
estimate δ̂, not the machine's true state: the part is probed with the machine as it is
(parameters Δ_t at the time of the task) and compensated with δ̂ = Δ_cal + ε, where ε is
the identification error (covariance U_θ, the calibration's GUF or Monte Carlo result)
and Δ_t = Δ_cal + d drifted by d since the calibration (long-term variation, covariance
Σ_lt).  The probed point is Ψ_s = f(γ_s, Δ_t) + e_s, read as φ_s = γ_s + ν_s (ν_s: probing
noise, covariance v_s), and compensated as q_s = f(φ_s, δ̂), so to first order

    q_s − Ψ_s = A_s ν_s + G_s (ε − d) − e_s,    A_s = ∂f/∂q, G_s = ∂f/∂δ,

and, the four sources being independent,

    U_q = ⊕ A_s v_s A_sᵀ  +  G U_θ Gᵀ  +  G Σ_lt Gᵀ  +  I_n ⊗ cov(e).

Nothing cancels: ε is independent of the readings' noise.  (The thesis' Populations I–IV
correlate Γ with the *same* Δ that compensates, which holds only when the readings are
compensated with the true parameters of the day; then G Σ_lt Gᵀ cancels, eq. 6-12 and
:func:`population_covariance`.)  The inputs are

    Γ   readings φ_s, covariance from Populations I, II and IV (§6.2.2) with Δ ~ N(δ̂, Σ_lt):
        the readings the machine as it drifted would need to reach the fixed workpiece;
        their parts from v_s ("repeatability") and from Σ_lt ("long_term_variation") are
        kept apart;
    Δ   δ̂ with covariance U_θ ("calibration"), independent of Γ;
    E   0 with I_n ⊗ cov(e) ("unexplained_volumetric_error").

U_x is the sum of these four independent components, so their first-order variances add
exactly to u² (the task's budget groups).  Σ_lt is left out (zero) when the machine is
recalibrated for the task.

Two ways to build the Γ block are offered:

``"linear"`` (default)
    Population IV linearised about (φ, δ̂):
    Γ_s − φ_s = L F_s⁻¹ [A_s (Φ_s − φ_s) − G_s (Δ − δ̂)], with F_s the linear-axis columns
    of A_s, so U_x is exact for the linearised model and has no sampling noise.
``"sampled"``
    The thesis' algorithm as printed (Q draws of Populations I–IV through the kinematic
    model and its inverse; Q = 10⁴ in the thesis), with the sample covariance of Γ, drawn
    once for the repeatability and once for the long-term variation.

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, §6.2 and Appendix A.3.

JCGM 100:2008. *Evaluation of measurement data — Guide to the expression of uncertainty in
measurement*, 5.1.2 (every input whose estimate is used contributes its variance).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import block_diag

from mtmetrology.errors import InputError
from mtmetrology.io.covariance import symmetric_covariance
from mtmetrology.kinematics.chain import ChainEvaluation
from mtmetrology.kinematics.machine import Machine
from mtmetrology.rng import SeedLike, as_generator, chunk_generators
from mtmetrology.uncertainty.distributions import MultivariateNormal
from mtmetrology.uncertainty.inputs import InputSet
from mtmetrology.units import internal_unit

__all__ = [
    "GROUPS",
    "SIMULATORS",
    "MeasurementModel",
    "TaskInputs",
    "covariance_simulator",
    "group_label",
    "population_covariance",
]

SIMULATORS = ("linear", "sampled")
#: The independent sources of a task's uncertainty, in budget order.
GROUPS = ("repeatability", "calibration", "long_term_variation", "unexplained_volumetric_error")


def group_label(group: str) -> str:
    """A source of :data:`GROUPS` in words: ``long_term_variation`` -> ``long-term variation``."""
    return group.replace("long_term", "long-term").replace("_", " ")


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
        x = [φ; δ̂; 0].
    covariance : (N, N) ndarray
        U_x (PSD, exactly symmetric): the sum of the :attr:`components`.
    n_points, n_axes, n_params : int
    simulator : {"linear", "sampled"}
    draws : int or None
        Q of the sampled simulator.
    at_estimate : ChainEvaluation
        The kinematic model at x: the compensated points f(φ_s, δ̂) (``position``, (n, 3))
        with ∂f/∂q (``d_axes``) and ∂f/∂δ (``d_params``), which the GUF reuses.
    components : dict of str to (slice, ndarray)
        The independent sources of U_x (:data:`GROUPS`): each one's block on its slice of x
        (zero elsewhere). ``repeatability`` and ``long_term_variation`` share the Γ slice.
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
    components: dict = field(repr=False, default_factory=dict)

    @property
    def dof(self) -> np.ndarray:
        """Degrees of freedom of the inputs: infinite (the covariances are taken as known)."""
        return np.full(len(self.names), np.inf)

    def input_set(self) -> InputSet:
        """The inputs as jointly normal quantities (for the GUF and Monte Carlo engines)."""
        return InputSet.from_covariance(self.names, self.estimate, self.covariance, self.units)

    def group_variances(self, sensitivities: np.ndarray) -> dict[str, np.ndarray]:
        """First-order variance c U_g cᵀ of each output from each source g.

        Parameters
        ----------
        sensitivities : (m, N) array
            ∂y/∂x of the outputs.

        Returns
        -------
        dict of str to (m,) ndarray
            They add to diag(c U_x cᵀ) (the components are independent and sum to U_x).
        """
        c = np.atleast_2d(sensitivities)
        return {
            g: np.einsum("mi,ij,mj->m", c[:, sl], block, c[:, sl])
            for g, (sl, block) in self.components.items()
        }


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
    calibration_covariance: np.ndarray,
    *,
    long_term_covariance: np.ndarray | None = None,
    reading_covariance: np.ndarray | None = None,
    unexplained_covariance: np.ndarray | None = None,
    senses: np.ndarray | None = None,
    simulator: str = "linear",
    draws: int = 10_000,
    seed: SeedLike = None,
) -> TaskInputs:
    """x = [φ; δ̂; 0] and U_x of a task compensated with a calibration (module notes).

    Parameters
    ----------
    machine : Machine
        With exactly three linear axes (Population IV solves for them).
    readings : (n, n_axes) array
        Probed readings φ_s (mm, rad).
    parameters : (P,) array
        The calibration's estimate δ̂ that compensates the readings (internal units,
        ``machine.parameter_names`` order).
    calibration_covariance : (P, P) array
        U_θ of δ̂ (the identification's covariance): always propagated, independent of the
        readings.
    long_term_covariance : (P, P) array, optional
        Σ_lt, the variation of the parameters between the calibration and the task
        (Population III); none when the machine is recalibrated for the task.
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
    The Γ block is the thesis' Populations I, II and IV (§6.2.2) with Population III drawn
    from Σ_lt; its cross-covariance with Δ is *not* kept, because Δ here is the
    calibration's estimate, fixed for the task, not the machine's state of the day
    (:func:`population_covariance` keeps it, the thesis' eq. 6-12).  To first order
    A_s (Γ_s − φ_s) = A_s (Φ_s − φ_s) − G_s (Δ − δ̂), so the long-term term adds
    G Σ_lt Gᵀ to U_q and the calibration term G U_θ Gᵀ.
    """
    if simulator not in SIMULATORS:
        raise InputError(f"simulator must be one of {', '.join(SIMULATORS)}, got {simulator!r}")
    q, delta, n_par = _check_readings(machine, readings, parameters)
    n, n_axes = q.shape
    u_theta = check_psd(calibration_covariance, (n_par, n_par), "calibration covariance")
    sigma = (
        np.zeros((n_par, n_par))
        if long_term_covariance is None
        else check_psd(long_term_covariance, (n_par, n_par), "long-term covariance")
    )
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
    linear, ev = _linear_axes(machine, q, delta, senses)
    size = n * n_axes + n_par + 3 * n
    if simulator == "sampled" and int(draws) < 2 * size:
        raise InputError(
            f"draws: the sampled simulator needs at least 2·N = {2 * size} draws for "
            f"{size} inputs, got {draws}"
        )
    gam = slice(0, n * n_axes)
    par = slice(n * n_axes, n * n_axes + n_par)
    err = slice(n * n_axes + n_par, size)
    zero_v, zero_sigma = np.zeros_like(v), np.zeros_like(sigma)
    rep_seed, lt_seed = (None, None) if simulator == "linear" else chunk_generators(seed, 2)

    def gamma_block(sig, vv, stream):
        if not (sig.any() or vv.any()):
            return np.zeros((n * n_axes, n * n_axes))
        if simulator == "linear":
            joint = _linear_population_covariance(ev, sig, vv, linear)
        else:
            joint = _sampled_population_covariance(
                machine, q, delta, sig, vv, senses, linear, int(draws), stream
            )
        return joint[gam, gam]

    components = {
        "repeatability": (gam, gamma_block(zero_sigma, v, rep_seed)),
        "calibration": (par, u_theta),
        "long_term_variation": (gam, gamma_block(sigma, zero_v, lt_seed)),
        "unexplained_volumetric_error": (err, np.kron(np.eye(n), cov_e)),
    }
    ux = np.zeros((size, size))
    for sl, block in components.values():
        ux[sl, sl] += block
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
        components,
    )


def population_covariance(
    machine: Machine,
    readings: np.ndarray,
    parameters: np.ndarray,
    parameter_covariance: np.ndarray,
    *,
    reading_covariance: np.ndarray | None = None,
    senses: np.ndarray | None = None,
    simulator: str = "linear",
    draws: int = 10_000,
    seed: SeedLike = None,
) -> np.ndarray:
    """Joint covariance of [Γ; Δ] of the thesis' Populations I–IV (§6.2.2, eq. 6-12).

    Γ_s = f⁻¹(f(Φ_s, δ); Δ) with Φ_s ~ N(φ_s, v_s) and Δ ~ N(δ, Σ): the readings a machine
    in state Δ needs, correlated with that same Δ.  Propagated through q = f(Γ, Δ) it
    gives U_q = ⊕ A_s v_s A_sᵀ whatever Σ is: the model of a task compensated with the
    machine's true parameters of the day.  A task compensated with a calibration uses
    :func:`covariance_simulator` instead.

    Parameters
    ----------
    machine, readings, senses, simulator, draws, seed
        As in :func:`covariance_simulator`.
    parameters : (P,) array
        δ.
    parameter_covariance : (P, P) array
        Σ.
    reading_covariance : (n, n_axes, n_axes) array, optional
        v_s.

    Returns
    -------
    (n·n_axes + P, n·n_axes + P) ndarray
    """
    if simulator not in SIMULATORS:
        raise InputError(f"simulator must be one of {', '.join(SIMULATORS)}, got {simulator!r}")
    q, delta, n_par = _check_readings(machine, readings, parameters)
    n, n_axes = q.shape
    sigma = check_psd(parameter_covariance, (n_par, n_par), "parameter covariance")
    v = (
        np.zeros((n, n_axes, n_axes))
        if reading_covariance is None
        else check_psd(reading_covariance, (n, n_axes, n_axes), "reading covariance")
    )
    linear, ev = _linear_axes(machine, q, delta, senses)
    if simulator == "linear":
        return _linear_population_covariance(ev, sigma, v, linear)
    return _sampled_population_covariance(
        machine, q, delta, sigma, v, senses, linear, int(draws), seed
    )


def _check_readings(machine, readings, parameters):
    q = np.asarray(readings, float)
    if q.ndim != 2 or q.shape[1] != machine.n_axes:
        raise InputError(
            f"readings must have shape (n, {machine.n_axes}) for machine {machine.name}, "
            f"got {q.shape}"
        )
    n_par = machine.n_params
    delta = np.asarray(parameters, float)
    if delta.shape != (n_par,) or not np.all(np.isfinite(delta)):
        raise InputError(f"parameters: expected {n_par} finite values, got shape {delta.shape}")
    return q, delta, n_par


def _linear_axes(machine, q, delta, senses):
    """Indices of the three linear axes and the kinematic model with its Jacobians at x."""
    linear = [machine.axis_names.index(x) for x in machine.linear_axes]
    if len(linear) != 3:
        raise InputError(f"machine {machine.name}: the task model needs three linear axes")
    ev = machine.evaluate(q, delta, senses=senses, d_params=True, d_axes=True)
    if np.any(np.abs(np.linalg.det(ev.d_axes[:, :, linear])) < 1e-12):
        raise InputError("the linear axes do not span space at a probed pose (singular ∂f/∂q)")
    return linear, ev


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
    """A finite, symmetric (to 1e-9 of its largest entry, then symmetrised), positive
    semidefinite (stack of) covariance matrix, or InputError."""
    m = np.asarray(matrix, float)
    if m.shape != shape or not np.all(np.isfinite(m)):
        raise InputError(f"{what}: expected finite values of shape {shape}, got {m.shape}")
    m = symmetric_covariance(m, what)  # the one symmetry rule of mtmetrology.io.covariance
    low = np.linalg.eigvalsh(m).min(axis=-1)
    scale = np.abs(m).max(axis=(-1, -2))
    if np.any(low < -1e-10 * np.maximum(scale, np.finfo(float).tiny)):
        raise InputError(
            f"{what}: not positive semidefinite (smallest eigenvalue {float(np.min(low)):.3g})"
        )
    return m
