"""What the minimax (Chebyshev-norm) fits share: the result object, its status and the
contacts that define a zone.

Used by :mod:`.minimum_zone` (exact hull methods) and :mod:`.minimax` (sequential
linear programming); see :mod:`mtmetrology.fitting.minimum_zone` for the definitions.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum
from typing import Literal

import numpy as np

from mtmetrology.display import NotebookRepr
from mtmetrology.fitting.elements import Circle, Cylinder, Line, Plane, Sphere

__all__ = [
    "CONTACT_RTOL",
    "ZONE_STATUS_MESSAGES",
    "Kind",
    "ZoneResult",
    "ZoneStatus",
    "contact_indices",
]

#: What a radial minimax fit minimises: the zone width, the largest distance (outer,
#: circumscribed) or minus the smallest (inner, inscribed).
Kind = Literal["zone", "outer", "inner"]


class ZoneStatus(IntEnum):
    """Why a Chebyshev fit stopped (> 0: converged).

    The codes follow :class:`mtmetrology.optimize.Status`: ``0`` is the iteration limit,
    ``2`` a stop at the rounding level, ``3`` an exact closed-form solution, negative codes
    a failure; ``1`` is the first-order optimality of the sequential LP (the linear
    programme predicts no decrease of the zone width above ``1e-13`` of the point-set
    size), its counterpart of the least-squares step tolerance.
    """

    LP_FAILED = -2
    TRUST_REGION_LIMIT = -1
    ITERATION_LIMIT = 0
    OPTIMAL = 1
    ROUNDING_LEVEL = 2
    EXACT = 3


#: One message per :class:`ZoneStatus`; ``{count}`` is the number of linear programmes.
ZONE_STATUS_MESSAGES = {
    ZoneStatus.LP_FAILED: "the linear programme failed (HiGHS) after {count}",
    ZoneStatus.TRUST_REGION_LIMIT: (
        "stopped after {count}: the trust region fell below the rounding level "
        "while the linear programme still predicted a decrease"
    ),
    ZoneStatus.ITERATION_LIMIT: "no convergence in {count}",
    ZoneStatus.OPTIMAL: "converged: {count}",
    ZoneStatus.ROUNDING_LEVEL: (
        "converged: {count}, the trust region fell below the rounding level"
    ),
    ZoneStatus.EXACT: "exact: minimum width of the convex hull (no linear programme)",
}


def _count(iterations: int) -> str:
    return f"{iterations} linear programme{'' if iterations == 1 else 's'}"


#: Contacts are the points within this fraction of the point-set size of a zone boundary:
#: far below any form error a CMM resolves, far above the rounding of the distances.
CONTACT_RTOL = 1e-9


@dataclass(frozen=True)
class ZoneResult(NotebookRepr):
    """A Chebyshev-type reference element and the zone it defines.

    Attributes
    ----------
    element : Line, Plane, Circle, Sphere or Cylinder
        The reference element: the mid-zone element for a minimum zone (mid plane, mean
        circle of the two concentric circles, ...), the axis of the smallest enclosing
        cylinder for a 3-D straightness, and the inscribed or circumscribed element itself.
    method : {"minimum-zone", "inscribed", "circumscribed"}
        What was solved.
    form_error : float
        Zone width, mm: the distance between the two planes or lines, the radial separation
        of the two circles, spheres or cylinders; the diameter of the smallest enclosing
        cylinder for a 3-D straightness; for an inscribed or circumscribed element the
        radial range of the points about it.
    bounds : tuple of float
        The two zone boundaries, mm: (inner, outer) radii for circles, spheres and
        cylinders; signed offsets (-t/2, t/2) of the two parallel lines or planes from the
        mid element; (0, radius) of the enclosing cylinder for a 3-D straightness.
    residuals : (n,) ndarray
        Deviations of the points from ``element``, mm (signed normal distances; radial
        distances from the axis for a 3-D straightness).
    contacts : (m,) ndarray of int
        Indices of the points on the zone boundaries: those that define the zone.
    least_squares_form_error : float
        Peak-to-valley of the residuals of the least-squares element the iteration
        started from, mm (same definition as ``form_error``), for comparison.
    iterations : int
        Linear programmes solved (0 for the exact hull methods).
    status : int
        A :class:`ZoneStatus` code; ``success`` and ``message`` derive from it.
    """

    element: Line | Plane | Circle | Sphere | Cylinder
    method: str
    form_error: float
    bounds: tuple[float, float]
    residuals: np.ndarray = field(repr=False)
    contacts: np.ndarray
    least_squares_form_error: float
    iterations: int
    status: int

    @property
    def success(self) -> bool:
        """Whether the fit converged (``status > 0``)."""
        return self.status > 0

    @property
    def converged(self) -> bool:
        """Alias of :attr:`success`, kept for the zone fits' callers."""
        return self.success

    @property
    def message(self) -> str:
        """What happened, in words, from :data:`ZONE_STATUS_MESSAGES`."""
        return ZONE_STATUS_MESSAGES[ZoneStatus(self.status)].format(count=_count(self.iterations))


def contact_indices(values: np.ndarray, level: float, tol: float) -> np.ndarray:
    """Indices of the points on a zone boundary: those whose ``values`` (distances) lie
    within ``tol`` of the boundary ``level`` (``tol = CONTACT_RTOL ×`` the point-set
    size)."""
    return np.flatnonzero(np.abs(values - level) <= tol)
