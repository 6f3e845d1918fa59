"""Sliding-window repeatability per target: how stable the scatter is over the series.

:func:`window_statistics` slides a window of w iterations along each target's touches (in
time order) and gives the standard deviation of the X, Y, Z readings and of their normal
projection N in every window (Sepahi Boroujeni (2021), §4, Fig. 4-20: w = 10 over
iterations 26–50).

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, §4.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.omm.drift import sliding_window_std
from mtmetrology.omm.repeatability import time_ordered_groups
from mtmetrology.units import from_internal

__all__ = ["WINDOW_OUTPUTS", "WindowStatistics", "window_statistics"]

WINDOW_OUTPUTS = ("sigma_X", "sigma_Y", "sigma_Z", "sigma_N")


@dataclass(frozen=True)
class WindowStatistics:
    """Standard deviations in a window sliding along each target's series.

    Attributes
    ----------
    window : int
        Touches per window.
    targets : tuple of str
        Target ids, in first-appearance order.
    starts : tuple of (n_w,) ndarray of int
        Per target, the iteration (1-based position of the touch in the target's time
        order, the first touch being iteration 1) at which each window starts.
    std : tuple of (n_w, 4) ndarray, mm
        Per target, σ of X, Y, Z, N in each window (:data:`WINDOW_OUTPUTS`, ddof = 1).
    """

    window: int
    targets: tuple[str, ...]
    starts: tuple[np.ndarray, ...]
    std: tuple[np.ndarray, ...]

    def to_dict(self) -> dict:
        """JSON block: per target the window starts and σ in µm."""
        return {
            "window": self.window,
            "iteration": "1-based position of a touch in its target's time order",
            "unit": "µm",
            "targets": [
                {
                    "target": name,
                    "start": starts.tolist(),
                    **{
                        n: from_internal(s[:, j], "µm").tolist()
                        for j, n in enumerate(WINDOW_OUTPUTS)
                    },
                }
                for name, starts, s in zip(self.targets, self.starts, self.std, strict=True)
            ],
        }


def window_statistics(
    target,
    readings: np.ndarray,
    normal: np.ndarray,
    time: np.ndarray,
    *,
    window: int = 10,
    first_iteration: int = 2,
    where: str = "records",
) -> WindowStatistics:
    """Sliding-window standard deviations of each target's readings.

    Parameters
    ----------
    target : (m,) sequence of str
        Target id of each touch.
    readings : (m, 3) array, mm
        Recorded X, Y, Z.
    normal : (m, 3) array
        Unit outward normal of the target (N = reading · n̂).
    time : (m,) array, s
        Orders the touches of a target.
    window : int, default 10
        Touches per window (Sepahi Boroujeni (2021): 10).
    first_iteration : int, default 2
        Iteration at which the first window starts (1-based; 2 skips the first touch,
        which carries the hysteresis of the preceding motion; the thesis uses 26, once
        the drift has settled).
    where : str
        Name of the source for error messages.

    Returns
    -------
    WindowStatistics

    Raises
    ------
    InputError
        ``window`` < 2, ``first_iteration`` < 1, or a target whose series is shorter than
        ``first_iteration`` + ``window`` − 1 (the message names the target).

    Notes
    -----
    The windows use the readings themselves: over a window of a few iterations after
    the drift has settled, the drift is negligible (Sepahi Boroujeni (2021), §4). σ_N
    is the scatter along the target normal; T, a distance, is not windowed.

    Examples
    --------
    >>> from mtmetrology.units import to_internal
    >>> x = to_internal(np.array([0.0, 1.0, 0.0, 1.0, 0.0, 3.0, 0.0]), "µm")
    >>> readings = np.column_stack([x, np.zeros(7), np.zeros(7)])
    >>> ws = window_statistics(["a"] * 7, readings, np.tile([1.0, 0, 0], (7, 1)),
    ...                        np.arange(7.0), window=4, first_iteration=2)
    >>> ws.starts[0].tolist(), from_internal(ws.std[0][:, 0], "µm").round(3).tolist()
    ([2, 3, 4], [0.577, 1.414, 1.414])
    """
    if int(first_iteration) != first_iteration or first_iteration < 1:
        raise InputError(f"first iteration: must be an integer >= 1, got {first_iteration}")
    names, starts, stds = [], [], []
    for name, idx in time_ordered_groups(target, time):
        p = readings[idx]
        n_proj = np.sum(p * normal[idx], axis=-1)
        begin, s = sliding_window_std(
            np.column_stack([p, n_proj]),
            window,
            start=first_iteration - 1,
            where=f"{where}: target {name!r}",
        )
        names.append(name)
        starts.append(begin + 1)
        stds.append(s)
    return WindowStatistics(int(window), tuple(names), tuple(starts), tuple(stds))
