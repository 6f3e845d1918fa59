"""ISO 230-4 results of a circular test: G, H and F per direction.

Definitions (ISO 230-4:2005, *Test code for machine tools — Part 4: Circular tests for
numerically controlled machine tools*, clause 3; the clause numbers are those of the 2005
edition):

- **circular deviation G** (3.2): the radial range of the actual path about the centre of
  its least-squares circle, ``G = max ρ_i − min ρ_i`` with ρ_i the distances of the path
  points from that centre; one value per direction;
- **circular hysteresis H** (3.3): the largest radial difference between the clockwise and
  counter-clockwise paths at the same angle, ``H = max_θ |ρ_ccw(θ) − ρ_cw(θ)|``; both paths
  are referred to the ballbar pivot (one centre for both runs), the counter-clockwise
  path interpolated linearly (period 360°) at the clockwise angles;
- **radial deviation F** (3.4): the deviation of the actual path from the nominal circle,
  ``F_max = max ℓ_i`` and ``F_min = min ℓ_i``, with the centre set by centring the
  instrument (the ballbar pivot), which the standard allows beside the least-squares
  centre; per direction.

The path point of sample i is (R + ℓ_i)(cos θ_i, sin θ_i) in the plane, about the pivot;
the least-squares circle is :func:`mtmetrology.fitting.batch.fit_circles` (Forbes §4.5),
batched over directions and tests.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology.ballbar.records import BallbarTest
from mtmetrology.units import from_internal

__all__ = ["CircularResults", "circular_deviation", "circular_results"]


def circular_deviation(angle: np.ndarray, reading: np.ndarray, radius: float) -> dict:
    """G, the least-squares centre and F of K runs at once (ISO 230-4:2005, 3.2 and 3.4).

    Parameters
    ----------
    angle : (K, n) ndarray
        θ of each sample, rad.
    reading : (K, n) ndarray
        ℓ of each sample, mm.
    radius : float
        Nominal radius R, mm.

    Returns
    -------
    dict
        ``G`` (K,), ``centre`` (K, 2) of the least-squares circle about the pivot,
        ``F_max`` and ``F_min`` (K,), all mm.
    """
    from mtmetrology.fitting.batch import fit_circles

    a = np.atleast_2d(angle)
    ell = np.atleast_2d(reading)
    rho = radius + ell
    points = np.stack([rho * np.cos(a), rho * np.sin(a)], axis=-1)
    fit = fit_circles(points)
    return {
        "G": fit.form_error,
        "centre": fit.centres,
        "F_max": ell.max(axis=1),
        "F_min": ell.min(axis=1),
    }


def _um(value: float) -> float:
    return float(from_internal(value, "µm"))


def _hysteresis(test: BallbarTest) -> float:
    ccw = test.direction == 1
    cw = ~ccw
    order = np.argsort(test.angle[ccw])
    at_cw = np.interp(
        test.angle[cw], test.angle[ccw][order], test.reading[ccw][order], period=2.0 * np.pi
    )
    return float(np.max(np.abs(at_cw - test.reading[cw])))


@dataclass(frozen=True)
class CircularResults:
    """ISO 230-4 results of one test (mm in the attributes, µm in the document).

    Attributes
    ----------
    name : str
    G : dict
        ``{"ccw": G, "cw": G}``.
    F_max, F_min : dict
        Per direction.
    centre : dict
        Least-squares centre per direction, (2,) in the plane about the pivot.
    H : float
    """

    name: str
    plane: str
    G: dict
    F_max: dict
    F_min: dict
    centre: dict
    H: float

    def to_dict(self) -> dict:
        return {
            "test": self.name,
            "plane": self.plane,
            "unit": "µm",
            "circular_deviation_G": {d: _um(v) for d, v in self.G.items()},
            "circular_hysteresis_H": _um(self.H),
            "radial_deviation_F": {
                d: {"max": _um(self.F_max[d]), "min": _um(self.F_min[d])} for d in self.F_max
            },
            "least_squares_centre_um": {d: [_um(c) for c in v] for d, v in self.centre.items()},
            "definitions": {
                "G": "ISO 230-4:2005, 3.2: radial range about the least-squares circle centre",
                "H": "ISO 230-4:2005, 3.3: largest |ccw − cw| radial difference at the same "
                "angle, both about the pivot",
                "F": "ISO 230-4:2005, 3.4: max and min of the reading ℓ, centre by instrument "
                "centring (the pivot)",
            },
        }


def circular_results(test: BallbarTest) -> CircularResults:
    """The ISO 230-4 results of one test, both directions in one batched fit.

    Parameters
    ----------
    test : BallbarTest

    Returns
    -------
    CircularResults
    """
    runs = {"ccw": test.direction == 1, "cw": test.direction == -1}
    counts = {d: int(m.sum()) for d, m in runs.items()}
    if counts["ccw"] == counts["cw"]:
        found = circular_deviation(
            np.stack([test.angle[m] for m in runs.values()]),
            np.stack([test.reading[m] for m in runs.values()]),
            test.conditions.radius,
        )
        per = {d: {k: v[i] for k, v in found.items()} for i, d in enumerate(runs)}
    else:
        per = {}
        for d, m in runs.items():
            found = circular_deviation(test.angle[m], test.reading[m], test.conditions.radius)
            per[d] = {k: v[0] for k, v in found.items()}
    return CircularResults(
        name=test.conditions.name,
        plane=test.conditions.plane,
        G={d: float(per[d]["G"]) for d in runs},
        F_max={d: float(per[d]["F_max"]) for d in runs},
        F_min={d: float(per[d]["F_min"]) for d in runs},
        centre={d: np.asarray(per[d]["centre"], dtype=float) for d in runs},
        H=_hysteresis(test),
    )
