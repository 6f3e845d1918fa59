"""Geometric elements of coordinate metrology: line, plane, circle, sphere, cylinder, cone.

Each element is a small frozen object validated at construction.  It knows its signed
orthogonal distance to points (positive outside the material-free side: along the plane
normal, outside a circle, sphere, cylinder or cone), the nearest points on it
(:meth:`project`), and a canonical parameter vector (:attr:`parameters`,
:attr:`parameter_names`) that the least-squares fits differentiate with respect to the
point coordinates (GUF propagation).

Parameterisations (all lengths in mm, angles in rad)
----------------------------------------------------
============  ==========================================  =====  =========================
element       parameters                                  count  constraints (dof)
============  ==========================================  =====  =========================
Line 2-D      x0, y0, ax, ay                              4      ‖a‖ = 1, point choice (2)
Line 3-D      x0, y0, z0, ax, ay, az                      6      ‖a‖ = 1, point choice (4)
Plane         x0, y0, z0, nx, ny, nz                      6      ‖n‖ = 1, point choice (3)
Circle 2-D    x0, y0, r                                   3      none (3)
Circle 3-D    x0, y0, z0, nx, ny, nz, r                   7      ‖n‖ = 1 (6)
Sphere        x0, y0, z0, r                               4      none (4)
Cylinder      x0, y0, z0, ax, ay, az, r                   7      ‖a‖ = 1, point choice (5)
Cone          x0, y0, z0 (apex), ax, ay, az, half_angle   7      ‖a‖ = 1 (6)
============  ==========================================  =====  =========================

The "point choice" of lines, planes and cylinders is fixed by the fits: the point is the
foot of the centroid of the fitted data on the element (the orthogonal projection of the
centroid), which is well conditioned even far from the coordinate origin.  The parameter
Jacobians of :mod:`mtmetrology.fitting.least_squares` include the dependence of that point
on the centroid, so the covariance of the redundant parameters is exact to first order
and rank deficient by the number of constraints.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["Circle", "Cone", "Cylinder", "Element", "Line", "Plane", "Sphere"]


def _vector(value: object, name: str, dims: tuple[int, ...]) -> np.ndarray:
    """A finite float vector of one of the allowed lengths (a read-only copy)."""
    arr = np.array(value, dtype=float)
    if arr.ndim != 1 or arr.shape[0] not in dims:
        raise ValueError(
            f"{name} must be a vector of length {' or '.join(map(str, dims))}, "
            f"got shape {arr.shape}"
        )
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {arr.tolist()}")
    arr.flags.writeable = False
    return arr


def _unit(value: object, name: str, dims: tuple[int, ...]) -> np.ndarray:
    arr = np.array(_vector(value, name, dims))
    norm = float(np.linalg.norm(arr))
    if norm == 0.0:
        raise ValueError(f"{name} must be a non-zero vector")
    arr = arr / norm
    arr.flags.writeable = False
    return arr


def _positive(value: object, name: str) -> float:
    x = float(value)  # type: ignore[arg-type]
    if not np.isfinite(x) or x <= 0.0:
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return x


def _points(points: object, dim: int, name: str = "points") -> np.ndarray:
    arr = np.asarray(points, dtype=float)
    if arr.ndim < 1 or arr.shape[-1] != dim:
        raise ValueError(f"{name} must have shape (..., {dim}), got {arr.shape}")
    return arr


def _radial(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Norms of v (..., d) and unit vectors (zero vectors map to zero)."""
    rho = np.linalg.norm(v, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.where(rho[..., None] > 0.0, v / rho[..., None], 0.0)
    return rho, u


@runtime_checkable
class Element(Protocol):
    """What every geometric element offers (structural interface)."""

    @property
    def dim(self) -> int: ...

    @property
    def parameter_names(self) -> tuple[str, ...]: ...

    @property
    def parameters(self) -> np.ndarray: ...

    def distances(self, points: object) -> np.ndarray: ...

    def project(self, points: object) -> np.ndarray: ...


@dataclass(frozen=True, eq=False)
class Line:
    """A straight line through ``point`` with unit ``direction`` (2-D or 3-D).

    Distances are signed in 2-D (positive on the side of the normal
    ``(-ay, ax)``, the direction turned by +90°) and non-negative in 3-D.
    """

    point: np.ndarray
    direction: np.ndarray

    def __post_init__(self) -> None:
        point = _vector(self.point, "line point", (2, 3))
        direction = _unit(self.direction, "line direction", (point.shape[0],))
        object.__setattr__(self, "point", point)
        object.__setattr__(self, "direction", direction)

    @property
    def dim(self) -> int:
        return self.point.shape[0]

    @property
    def normal(self) -> np.ndarray:
        """The 2-D normal ``(-ay, ax)`` that gives distances their sign."""
        if self.dim != 2:
            raise ValueError("a 3-D line has no unique normal")
        return np.array([-self.direction[1], self.direction[0]])

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return ("x0", "y0", "ax", "ay") if self.dim == 2 else ("x0", "y0", "z0", "ax", "ay", "az")

    @property
    def parameters(self) -> np.ndarray:
        return np.concatenate([self.point, self.direction])

    def distances(self, points: object) -> np.ndarray:
        """Orthogonal distances, (..., dim) -> (...,); signed in 2-D, ≥ 0 in 3-D."""
        v = _points(points, self.dim) - self.point
        if self.dim == 2:
            return v @ self.normal
        return np.linalg.norm(v - (v @ self.direction)[..., None] * self.direction, axis=-1)

    def project(self, points: object) -> np.ndarray:
        """Feet of the points on the line, (..., dim)."""
        v = _points(points, self.dim) - self.point
        return self.point + (v @ self.direction)[..., None] * self.direction


@dataclass(frozen=True, eq=False)
class Plane:
    """A plane through ``point`` with unit ``normal``; distances positive along the normal."""

    point: np.ndarray
    normal: np.ndarray
    dim = 3
    parameter_names = ("x0", "y0", "z0", "nx", "ny", "nz")

    def __post_init__(self) -> None:
        object.__setattr__(self, "point", _vector(self.point, "plane point", (3,)))
        object.__setattr__(self, "normal", _unit(self.normal, "plane normal", (3,)))

    @property
    def parameters(self) -> np.ndarray:
        return np.concatenate([self.point, self.normal])

    def distances(self, points: object) -> np.ndarray:
        """Signed distances ``(p − x0)·n``, (..., 3) -> (...,)."""
        return (_points(points, 3) - self.point) @ self.normal

    def project(self, points: object) -> np.ndarray:
        p = _points(points, 3)
        return p - self.distances(p)[..., None] * self.normal


@dataclass(frozen=True, eq=False)
class Circle:
    """A circle: 2-D when ``normal`` is None, else a circle in the plane through ``centre``.

    For a 3-D circle, :meth:`distances` is the radial deviation of the points'
    projections on the circle's plane, ``ρ − r`` with ``ρ`` the in-plane distance to the
    centre: the quantity whose spread is the roundness (ISO 12181-1), and the residual
    minimised by the in-plane least-squares circle.
    """

    centre: np.ndarray
    radius: float
    normal: np.ndarray | None = None

    def __post_init__(self) -> None:
        centre = _vector(self.centre, "circle centre", (2, 3))
        if self.normal is None and centre.shape[0] == 3:
            raise ValueError("a 3-D circle needs a normal (the normal of its plane)")
        if self.normal is not None:
            if centre.shape[0] != 3:
                raise ValueError("a 2-D circle takes no normal")
            object.__setattr__(self, "normal", _unit(self.normal, "circle normal", (3,)))
        object.__setattr__(self, "centre", centre)
        object.__setattr__(self, "radius", _positive(self.radius, "circle radius"))

    @property
    def dim(self) -> int:
        return self.centre.shape[0]

    @property
    def parameter_names(self) -> tuple[str, ...]:
        if self.normal is None:
            return ("x0", "y0", "r")
        return ("x0", "y0", "z0", "nx", "ny", "nz", "r")

    @property
    def parameters(self) -> np.ndarray:
        if self.normal is None:
            return np.append(self.centre, self.radius)
        return np.concatenate([self.centre, self.normal, [self.radius]])

    def _in_plane(self, points: object) -> np.ndarray:
        v = _points(points, self.dim) - self.centre
        if self.normal is not None:
            v = v - (v @ self.normal)[..., None] * self.normal
        return v

    def distances(self, points: object) -> np.ndarray:
        """Radial deviations ``ρ − r`` (in the circle's plane), (..., dim) -> (...,)."""
        return np.linalg.norm(self._in_plane(points), axis=-1) - self.radius

    def project(self, points: object) -> np.ndarray:
        """Nearest points on the circle (the centre's projection maps to the centre)."""
        _, u = _radial(self._in_plane(points))
        return self.centre + self.radius * u


@dataclass(frozen=True, eq=False)
class Sphere:
    """A sphere; distances ``‖p − c‖ − r`` (positive outside)."""

    centre: np.ndarray
    radius: float
    dim = 3
    parameter_names = ("x0", "y0", "z0", "r")

    def __post_init__(self) -> None:
        object.__setattr__(self, "centre", _vector(self.centre, "sphere centre", (3,)))
        object.__setattr__(self, "radius", _positive(self.radius, "sphere radius"))

    @property
    def parameters(self) -> np.ndarray:
        return np.append(self.centre, self.radius)

    def distances(self, points: object) -> np.ndarray:
        return np.linalg.norm(_points(points, 3) - self.centre, axis=-1) - self.radius

    def project(self, points: object) -> np.ndarray:
        _, u = _radial(_points(points, 3) - self.centre)
        return self.centre + self.radius * u


@dataclass(frozen=True, eq=False)
class Cylinder:
    """A cylinder of ``radius`` about the axis through ``point`` along unit ``direction``.

    Distances ``ρ − r`` with ``ρ`` the distance to the axis (positive outside).
    """

    point: np.ndarray
    direction: np.ndarray
    radius: float
    dim = 3
    parameter_names = ("x0", "y0", "z0", "ax", "ay", "az", "r")

    def __post_init__(self) -> None:
        object.__setattr__(self, "point", _vector(self.point, "cylinder point", (3,)))
        object.__setattr__(self, "direction", _unit(self.direction, "cylinder direction", (3,)))
        object.__setattr__(self, "radius", _positive(self.radius, "cylinder radius"))

    @property
    def parameters(self) -> np.ndarray:
        return np.concatenate([self.point, self.direction, [self.radius]])

    def _radial(self, points: object) -> tuple[np.ndarray, np.ndarray]:
        v = _points(points, 3) - self.point
        foot = self.point + (v @ self.direction)[..., None] * self.direction
        return foot, _points(points, 3) - foot

    def distances(self, points: object) -> np.ndarray:
        return np.linalg.norm(self._radial(points)[1], axis=-1) - self.radius

    def project(self, points: object) -> np.ndarray:
        foot, w = self._radial(points)
        return foot + self.radius * _radial(w)[1]


@dataclass(frozen=True, eq=False)
class Cone:
    """A (one-nappe) cone with ``apex``, unit axis ``direction`` pointing into the cone
    (the radius grows along it) and ``half_angle`` ψ in (0, π/2).

    Notes
    -----
    With ``z = (p − apex)·a`` and ``ρ`` the distance of ``p`` to the axis, the signed
    orthogonal distance to the cone surface is ``d = ρ cos ψ − z sin ψ`` (positive
    outside; Forbes, NPL DITC 140/89, §4.9), valid for points whose foot lies on the
    nappe (``ρ sin ψ + z cos ψ ≥ 0``), which is where measured points lie.
    """

    apex: np.ndarray
    direction: np.ndarray
    half_angle: float
    dim = 3
    parameter_names = ("x0", "y0", "z0", "ax", "ay", "az", "half_angle")

    def __post_init__(self) -> None:
        object.__setattr__(self, "apex", _vector(self.apex, "cone apex", (3,)))
        object.__setattr__(self, "direction", _unit(self.direction, "cone direction", (3,)))
        psi = float(self.half_angle)
        if not np.isfinite(psi) or not 0.0 < psi < np.pi / 2:
            raise ValueError(f"cone half_angle must lie in (0, π/2) rad, got {self.half_angle!r}")
        object.__setattr__(self, "half_angle", psi)

    @property
    def parameters(self) -> np.ndarray:
        return np.concatenate([self.apex, self.direction, [self.half_angle]])

    def _axial_radial(self, points: object) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        v = _points(points, 3) - self.apex
        z = v @ self.direction
        rho, u = _radial(v - z[..., None] * self.direction)
        return z, rho, u

    def distances(self, points: object) -> np.ndarray:
        z, rho, _ = self._axial_radial(points)
        return rho * np.cos(self.half_angle) - z * np.sin(self.half_angle)

    def project(self, points: object) -> np.ndarray:
        z, rho, u = self._axial_radial(points)
        psi = self.half_angle
        # Outward unit normal of the cone at the foot: cos ψ ρ̂ − sin ψ a.
        normal = np.cos(psi) * u - np.sin(psi) * self.direction
        d = rho * np.cos(psi) - z * np.sin(psi)
        return _points(points, 3) - d[..., None] * normal
