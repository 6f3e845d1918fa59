"""Shared pieces of the minimax (Chebyshev-norm) fits: the result object and its status.

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
from mtmetrology.fitting.validation import FitError

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


# Contacts are the points within this fraction of the point-set size of a zone boundary:
# far below any form error a CMM resolves, far above the rounding of the distances.
_CONTACT_RTOL = 1e-9
_MAX_ITERATIONS = 200


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


# --------------------------------------------------------------------------------------
# geometry helpers


def _principal_axes(p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centroid, singular values and principal directions (rows) of a point set."""
    centroid = p.mean(axis=0)
    _, s, vt = np.linalg.svd(p - centroid, full_matrices=False)
    return centroid, s, vt


def _check_normal(normal) -> np.ndarray:
    n = np.asarray(normal, dtype=float)
    if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) == 0.0:
        raise FitError(f"normal must be a finite, non-zero 3-vector, got {normal!r}")
    return n / np.linalg.norm(n)


def _plane_basis(normal: np.ndarray) -> np.ndarray:
    """Rows u, v, n: a right-handed orthonormal frame whose third axis is ``normal``."""
    helper = np.eye(3)[int(np.argmin(np.abs(normal)))]
    u = np.cross(normal, helper)
    u /= np.linalg.norm(u)
    return np.stack([u, np.cross(normal, u), normal])


def _contacts(values: np.ndarray, level: float, tol: float) -> np.ndarray:
    return np.flatnonzero(np.abs(values - level) <= tol)


def _size(p: np.ndarray) -> float:
    """Radius of the point set about its centroid: the scale of its coordinates."""
    return float(np.max(np.linalg.norm(p - p.mean(axis=0), axis=1)))
