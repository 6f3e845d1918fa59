"""Several characteristics of one point set as one multivariate feature.

A measurement task often reports more than one characteristic of the same points: the
diameter and the sphericity of a sphere, the coordinates of every point with the length
between them (Sepahi Boroujeni (2021), Tables 7-1 and 7-2).  Propagating them together
keeps their correlation, which the JCGM 102:2011 validation (λ_max, the hyper-ellipsoid
k_p) and a joint coverage region need.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["CombinedFeature", "PointCoordinates"]


@dataclass(frozen=True)
class PointCoordinates:
    """The coordinates of the points themselves: outputs ``X_1, Y_1, Z_1, ..., Z_n``.

    ``value`` returns (..., 3n), ``jacobian`` the identity (3n, 3n).
    """

    n_points: int
    name: str = "points"
    unit: str = "mm"

    @property
    def min_points(self) -> int:
        return self.n_points

    @property
    def output_names(self) -> tuple[str, ...]:
        return tuple(f"{c}_{s + 1}" for s in range(self.n_points) for c in "XYZ")

    def _check(self, points: np.ndarray) -> np.ndarray:
        p = np.asarray(points, dtype=float)
        if p.shape[-2:] != (self.n_points, 3):
            raise ValueError(
                f"{self.name}: expected points of shape (..., {self.n_points}, 3), got {p.shape}"
            )
        return p

    def value(self, points: object) -> np.ndarray:
        p = self._check(points)
        return p.reshape(*p.shape[:-2], 3 * self.n_points)

    def jacobian(self, points: object) -> np.ndarray:
        self._check(points)
        return np.eye(3 * self.n_points)


@dataclass(frozen=True)
class CombinedFeature:
    """The outputs of several features of the same points, in order.

    Parameters
    ----------
    features : tuple of Feature
        Each with ``value``, ``jacobian``, ``output_names`` and the same ``unit``.

    Examples
    --------
    >>> import numpy as np
    >>> from mtmetrology.fitting.features import SphereDiameter, Sphericity
    >>> d = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0.6, 0, 0.8]])
    >>> f = CombinedFeature((SphereDiameter(), Sphericity()))
    >>> f.output_names
    ('sphere_diameter', 'sphericity')
    >>> np.round(f.value(5.0 * d), 12).tolist()
    [10.0, 0.0]
    >>> f.jacobian(5.0 * d).shape
    (2, 18)
    """

    features: tuple
    name: str = "features"

    def __post_init__(self) -> None:
        if not self.features:
            raise ValueError("CombinedFeature needs at least one feature")
        units = {f.unit for f in self.features}
        if len(units) != 1:
            raise ValueError(f"CombinedFeature: the features differ in unit ({sorted(units)})")
        names = [n for f in self.features for n in f.output_names]
        if len(set(names)) != len(names):
            raise ValueError(f"CombinedFeature: repeated output names {names}")

    @property
    def unit(self) -> str:
        return self.features[0].unit

    @property
    def min_points(self) -> int:
        return max(f.min_points for f in self.features)

    @property
    def output_names(self) -> tuple[str, ...]:
        return tuple(n for f in self.features for n in f.output_names)

    def value(self, points: object) -> np.ndarray:
        parts = []
        for f in self.features:
            v = np.asarray(f.value(points), dtype=float)
            parts.append(v[..., None] if len(f.output_names) == 1 else v)
        out = np.concatenate(parts, axis=-1)
        return out[..., 0] if out.shape[-1] == 1 else out

    def jacobian(self, points: object) -> np.ndarray:
        return np.vstack([np.atleast_2d(f.jacobian(points)) for f in self.features])
