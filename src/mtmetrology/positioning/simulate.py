"""Virtual ISO 230-2 tests of an axis with known errors.

The deviations are what the kinematic chain gives for the true parameters (``E_XX`` and
``E_XXb`` of the axis, :mod:`mtmetrology.positioning.identify`) at each target and sense,
plus a reading scatter drawn once per reading:

    x_ij = [p(q_i, s; θ) − p(q_i, s; 0)]_a + σ ε_ij,   ε_ij ~ N(0, 1).

ISO 230-2 asks for targets at irregular spacing (so that periodic errors of the scale or
the leadscrew are sampled at different phases): :func:`iso_targets` gives m targets over a
travel at the nominal pitch plus a fixed pseudo-random offset each.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.positioning.data import Conditions, PositioningTest
from mtmetrology.positioning.identify import readings_along
from mtmetrology.rng import SeedLike, as_generator

__all__ = ["iso_targets", "simulate_many", "simulate_test", "true_deviation"]

_COMPONENT = {"X": 0, "Y": 1, "Z": 2}


def iso_targets(low: float, high: float, m: int, seed: SeedLike = 0) -> np.ndarray:
    """m targets from ``low`` to ``high`` (mm): ends exact, the inner ones at the nominal
    pitch plus an offset drawn uniformly within ±1/4 pitch (irregular spacing).

    Raises
    ------
    InputError
        Fewer than 2 targets, or high ≤ low.
    """
    if m < 2 or not high > low:
        raise InputError(f"targets: {m} over {low:g} to {high:g} mm; give m ≥ 2 and low < high")
    pitch = (high - low) / (m - 1)
    t = low + pitch * np.arange(m)
    t[1:-1] += as_generator(seed).uniform(-0.25, 0.25, m - 2) * pitch
    return t


def true_deviation(machine: Machine, truth: ParameterSet, axis: str, targets: np.ndarray):
    """The true deviation ``[p(q, s; θ) − p(q, s; 0)]_a`` of ``axis`` at each target for
    senses +1 and −1, shape (m, 2), mm (the kinematic chain's own)."""
    m = truth.machine_for(machine)
    theta = truth.vector_for(m)
    q = readings_along(m, axis, targets)
    out = np.empty((targets.size, 2))
    k = m.axis_names.index(axis)
    for d, sense in enumerate((1.0, -1.0)):
        senses = np.zeros_like(q)
        senses[:, k] = sense
        p = m.forward(q, theta, senses=senses) - m.forward(q, np.zeros_like(theta), senses=senses)
        out[:, d] = p[:, _COMPONENT[axis]]
    return out


def simulate_test(
    machine: Machine,
    truth: ParameterSet,
    axis: str,
    targets: np.ndarray,
    *,
    runs: int = 5,
    sigma_mm: float = 0.0005,
    conditions: Conditions | None = None,
    seed: SeedLike = None,
) -> PositioningTest:
    """One virtual ISO 230-2 test (deviations as the environment-corrected ones).

    Parameters
    ----------
    machine : Machine
    truth : ParameterSet
        The true errors (``E_XX`` terms and ``E_XXb`` of the axis at least).
    axis : str
    targets : ndarray, shape (m,)
        Target positions, mm.
    runs : int
        Runs per direction.
    sigma_mm : float
        Standard deviation of one reading's scatter, mm.
    conditions : Conditions, optional
        Stated with the test (20 °C and the air as corrected: nothing to correct).
    seed : seed-like

    Returns
    -------
    PositioningTest
    """
    if axis not in _COMPONENT:
        raise InputError(f"axis: {axis!r} is not a linear axis X, Y or Z")
    true = true_deviation(machine, truth, axis, np.asarray(targets, float))
    noise = as_generator(seed).standard_normal((len(targets), runs, 2)) * sigma_mm
    cond = conditions or Conditions(
        axis=axis,
        travel_mm=[float(targets[0]), float(targets[-1])],
        air_compensated=True,
        nde_applied=True,
    )
    return PositioningTest(
        np.asarray(targets, float), true[:, None, :] + noise, cond, "<simulated>"
    )


def simulate_many(
    tests: int, targets: int, runs: int, *, sigma: float = 1.0, seed: SeedLike = None
) -> np.ndarray:
    """Deviations of many synthetic tests, shape (tests, targets, runs, 2) (the benchmark's
    input): a cubic error, a reversal and scatter σ per reading, in µm."""
    rng = as_generator(seed)
    u = np.linspace(-1.0, 1.0, targets)
    c = rng.normal(0.0, 5.0, (tests, 3))
    b = rng.normal(2.0, 1.0, (tests, 1))
    e = c[:, :1] * u + c[:, 1:2] * (1.5 * u**2 - 0.5) + c[:, 2:] * u**3
    x = rng.standard_normal((tests, targets, runs, 2)) * sigma
    x += e[:, :, None, None]
    x[..., 0] += 0.5 * b[:, :, None]
    x[..., 1] -= 0.5 * b[:, :, None]
    return x
