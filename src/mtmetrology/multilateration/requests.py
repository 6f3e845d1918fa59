"""The multilateration commands as library calls: pose grids, reflector tools, and
:func:`calibrate_multilateration_file` (``mtm multilateration calibrate``)."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from mtmetrology._memory import require_memory
from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.multilateration.files import read_lengths
from mtmetrology.multilateration.problem import parse_spec
from mtmetrology.multilateration.workflow import (
    BYTES_PER_LENGTH,
    MultilaterationResult,
    calibrate_multilateration,
    map_monte_carlo,
)

__all__ = [
    "DEFAULT_TOOL_OFFSETS",
    "calibrate_multilateration_file",
    "pose_grid",
    "reflector_tools",
    "volume_points",
]

#: Reflector offsets from the machine's tool when none is given: on the spindle axis and
#: two lateral ones, so that the yaws of the tool-side axes are observable.
DEFAULT_TOOL_OFFSETS = ((0.0, 0.0, 0.0), (80.0, 0.0, -50.0), (0.0, 80.0, -50.0))


def pose_grid(machine: Machine, counts) -> np.ndarray:
    """Readings (mm) of a regular grid over the travel of the linear axes.

    Parameters
    ----------
    machine : Machine
        Its linear axes need ``travel_mm``; the other axes stay at 0.
    counts : sequence of int
        Nodes per linear axis (at least 2 each), in axis order.

    Returns
    -------
    (∏ counts, n_axes) ndarray

    Raises
    ------
    InputError
        Not one count >= 2 per linear axis, an axis without travel.
    ResourceLimitError
        A grid larger than the memory holds (the grid itself, and one length row of
        :data:`~mtmetrology.multilateration.workflow.BYTES_PER_LENGTH` per node), refused
        before it is built.
    """
    linear = [a for a in machine.axis_names if machine.axes[a].linear]
    if len(counts) != len(linear) or min(counts, default=0) < 2:
        raise InputError(
            f"--grid needs {len(linear)} node counts >= 2 (axes {''.join(linear)}), "
            f"got {','.join(map(str, counts))!r}"
        )
    nodes = math.prod(int(n) for n in counts)
    require_memory(
        nodes * BYTES_PER_LENGTH,
        f"--grid {','.join(map(str, counts))}: {nodes} poses x {BYTES_PER_LENGTH} bytes",
    )
    axes = []
    for a, n in zip(linear, counts, strict=True):
        travel = machine.axes[a].travel
        if travel is None:
            raise InputError(f"--grid: axis {a} of {machine.name} has no travel_mm")
        axes.append(np.linspace(*travel, n))
    nodes = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, len(linear))
    q = np.zeros((len(nodes), machine.n_axes))
    q[:, [machine.axis_names.index(a) for a in linear]] = nodes
    return q


def reflector_tools(machine: Machine, tools=None) -> np.ndarray:
    """Reflector vectors (k, 3), mm: ``tools`` as given, else the machine's tool and the
    :data:`DEFAULT_TOOL_OFFSETS` from it."""
    if tools:
        return np.array(tools, dtype=float).reshape(-1, 3)
    return machine.tool + np.array(DEFAULT_TOOL_OFFSETS)


def volume_points(machine: Machine, readings: np.ndarray, n: int = 3) -> np.ndarray:
    """n³ points on a grid over the box of the nominal tool points of ``readings``, mm."""
    pos = machine.forward(readings)
    axes = [np.linspace(pos[:, k].min(), pos[:, k].max(), n) for k in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)


def calibrate_multilateration_file(
    lengths: str | Path,
    machine: Machine,
    *,
    noise: str = "0.2um+0.3um/m",
    mc: int = 0,
    seed: int | None = None,
    adequacy: str = "scale",
    progress=None,
) -> MultilaterationResult:
    """Identify the machine's errors from a LENGTHS.csv of a sequential multilateration.

    Parameters
    ----------
    lengths : path
        ``station,<axes>,tool_x,tool_y,tool_z,length`` (mm, rotary axes in degrees).
    machine : Machine
        With the error model to identify.
    noise : str
        Length uncertainty U(k=2) = A + B·L (:func:`~mtmetrology.multilateration.problem.
        parse_spec`); the weights are 1/u(ℓ).
    mc : int
        Monte Carlo trials checking the map uncertainty at 27 points of the measured
        volume (:func:`~mtmetrology.multilateration.workflow.map_monte_carlo`); 0: none,
        else at least 2.
    seed : int, optional
        Seed of the check.
    adequacy : {"scale", "a-priori"}
        The identification engine's model-adequacy rule (``"a-priori"``:
        ``--keep-a-priori-covariance``); the check draws the noise the covariance stands for.
    progress : callable, optional
        ``progress(done, mc)`` over the check's trials, for a progress display.

    Returns
    -------
    MultilaterationResult
        With ``map_check`` when ``mc`` > 0.
    """
    if mc < 0 or mc == 1:  # one draw has no standard deviation: a NaN uncertainty
        raise InputError(f"--mc must be 0 (no check) or at least 2 trials, got {mc}")
    record = read_lengths(lengths, machine)
    result = calibrate_multilateration(
        machine,
        record,
        spec=parse_spec(noise),
        provenance={"lengths": str(lengths)},
        adequacy=adequacy,
    )
    if not mc:
        return result
    points = volume_points(machine, record.readings)
    check = map_monte_carlo(
        machine, record, result, points, trials=mc, seed=seed, progress=progress
    )
    return replace(result, map_check=check)
