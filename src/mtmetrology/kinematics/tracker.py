"""Laser-tracker instrument model: pose, spherical measurement, limits and noise.

Measurement model (Aguado et al. (2019), eqs 2, 21–24).  A tracker at pose
``(T, R)``, ``T = (D, L, H)`` its position in the machine frame (mm) and
``R = R_x(α)·R_y(β)·R_z(δ)`` its orientation (eq. 22), sees a machine point ``p`` at::

    p_LT = Rᵀ·(p − T)                                   (eq. 2, outermost factor)
    p_LT = r·(cos e·cos a, cos e·sin a, sin e)            (range r, azimuth a, elevation e)

and reads ``(r, a, e)`` with independent normal errors of standard deviations::

    u_r = u_r0 + k_r·r        (4 µm + 0.8 µm/m, A3.2 of the digest)
    u_a = u_e = u_angle       (20 µrad; the level itself N(20, 3) µrad, drawn per test)

plus an isotropic SMR-centring error ``u_SMR`` (independent of the reading).  To first
order the point covariance in the tracker frame is ``Σ_p = J·diag(u_r², u_e², u_a²)·Jᵀ +
u_SMR²·I`` with J = ∂p_LT/∂(r, e, a); eq. 23 of the paper keeps only the diagonal of
``J·Σ·Jᵀ`` (:func:`eq23_variances`), the full matrix keeps the correlations between the
Cartesian components, which reach ±0.9 for a point seen at a shallow angle.

Conventions settled here (the paper's [UNCERTAIN] points, digest A2.6–A2.8):

- eq. 23 is the Jacobian of ``x = r·sinθ·cosφ, y = r·sinθ·sinφ, z = r·cosθ``: θ is the polar
  angle, so the elevation ``e = 90° − θ``; the paper's limits −45° ≤ θ ≤ 45° and
  −235° ≤ φ ≤ 235° are a tracker's elevation and azimuth limits and are enforced as such.
  The azimuth is reported in (−180°, 180°] and therefore always within ±235°: the limit
  matters only to a tracker that follows a path continuously.
- ``D, L, H`` lie along the machine's x, y, z (the paper's pose then gives ranges of
  1.39–1.85 m and elevations −19.3° to −8.8° over the mesh, as the digest derived).
- ``R⁻¹ = Rᵀ`` exactly (R is a rotation); eq. 25's "R + random matrix" is replaced by a
  perturbation on the rotation group, ``R·exp([ω]×)``, which stays orthonormal
  (:func:`perturb_pose`).

References
----------
S. Aguado, P. Pérez, J. A. Albajez, J. Santolaria, J. Velázquez, "Study on machine tool
positioning uncertainty due to volumetric verification", *Sensors* 19 (2019) 2847,
eqs 2, 21–26, Section 3.
ASME B89.4.19-2006, *Performance evaluation of laser-based spherical coordinate measurement
systems*.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.units import from_internal, to_internal

__all__ = [
    "TrackerLimits",
    "TrackerNoise",
    "TrackerPose",
    "cartesian",
    "eq23_variances",
    "euler_angles",
    "euler_matrix",
    "perturb_pose",
    "point_covariance",
    "spherical",
    "spherical_jacobian",
]

_DEG = float(to_internal(1.0, "°"))
_UM = float(to_internal(1.0, "µm"))
_URAD = float(to_internal(1.0, "µrad"))
_UM_PER_M = float(to_internal(1.0, "µm/m"))


def euler_matrix(alpha, beta, delta) -> np.ndarray:
    """Tracker orientation ``R_x(α)·R_y(β)·R_z(δ)`` (Aguado et al. (2019), eq. 22).

    Parameters
    ----------
    alpha, beta, delta : array_like
        Euler angles, rad; broadcast against each other.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``[[cβcδ, −cβsδ, sβ], [cαsδ + sαsβcδ, cαcδ − sαsβsδ, −sαcβ],
        [sαsδ − cαsβcδ, sαcδ + cαsβsδ, cαcβ]]``.

    Examples
    --------
    >>> import numpy as np
    >>> r = euler_matrix(0.0, 0.0, np.pi / 2)
    >>> np.round(r @ [1.0, 0.0, 0.0], 12) + 0.0
    array([0., 1., 0.])
    """
    a, b, d = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (alpha, beta, delta)))
    ca, sa, cb, sb, cd, sd = np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(d), np.sin(d)
    rows = [
        [cb * cd, -cb * sd, sb],
        [ca * sd + sa * sb * cd, ca * cd - sa * sb * sd, -sa * cb],
        [sa * sd - ca * sb * cd, sa * cd + ca * sb * sd, ca * cb],
    ]
    return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)


def euler_angles(rotation: np.ndarray) -> np.ndarray:
    """The angles (α, β, δ), rad, of a rotation ``R_x(α)·R_y(β)·R_z(δ)`` (|β| < 90°)."""
    r = np.asarray(rotation, dtype=float)
    alpha = np.arctan2(-r[..., 1, 2], r[..., 2, 2])
    beta = np.arcsin(np.clip(r[..., 0, 2], -1.0, 1.0))
    delta = np.arctan2(-r[..., 0, 1], r[..., 0, 0])
    return np.stack([alpha, beta, delta], axis=-1)


def _euler_derivatives(angles: np.ndarray) -> np.ndarray:
    """∂R/∂(α, β, δ), shape (..., 3, 3, 3): the last axis is the angle."""
    a, b, d = (angles[..., i] for i in range(3))
    zero, one = np.zeros_like(a), np.ones_like(a)

    def rx(t):
        c, s = np.cos(t), np.sin(t)
        return np.stack(
            [np.stack(r, -1) for r in ([one, zero, zero], [zero, c, -s], [zero, s, c])], -2
        )

    def ry(t):
        c, s = np.cos(t), np.sin(t)
        return np.stack(
            [np.stack(r, -1) for r in ([c, zero, s], [zero, one, zero], [-s, zero, c])], -2
        )

    def rz(t):
        c, s = np.cos(t), np.sin(t)
        return np.stack(
            [np.stack(r, -1) for r in ([c, -s, zero], [s, c, zero], [zero, zero, one])], -2
        )

    gx = np.array([[0.0, 0, 0], [0, 0, -1], [0, 1, 0]])
    gy = np.array([[0.0, 0, 1], [0, 0, 0], [-1, 0, 0]])
    gz = np.array([[0.0, -1, 0], [1, 0, 0], [0, 0, 0]])
    x, y, z = rx(a), ry(b), rz(d)
    da = gx @ x @ y @ z
    db = x @ (gy @ y) @ z
    dd = x @ y @ (gz @ z)
    return np.stack([da, db, dd], axis=-1)


@dataclass(frozen=True)
class TrackerPose:
    """Position and orientation of a laser tracker in the machine frame.

    Attributes
    ----------
    position : (3,) ndarray
        ``T_LT = (D, L, H)`` along the machine's x, y, z (eq. 21), mm.
    angles : (3,) ndarray
        Euler angles (α, β, δ) of eq. 22, rad: ``R = R_x(α)·R_y(β)·R_z(δ)`` maps tracker
        axes to machine axes; a positive δ turns the tracker's x axis towards machine +y.
    """

    position: np.ndarray
    angles: np.ndarray

    def __post_init__(self):
        for name in ("position", "angles"):
            v = np.asarray(getattr(self, name), dtype=float)
            if v.shape != (3,) or not np.all(np.isfinite(v)):
                raise InputError(f"tracker pose: {name} must be three finite numbers, got {v}")
            object.__setattr__(self, name, v)

    @classmethod
    def from_customary(cls, d, l, h, alpha, beta, delta) -> TrackerPose:
        """A pose from D, L, H in mm and α, β, δ in degrees."""
        return cls(np.array([d, l, h], float), np.array([alpha, beta, delta], float) * _DEG)

    @classmethod
    def from_vector(cls, x) -> TrackerPose:
        """From ``(D, L, H, α, β, δ)`` in mm and rad (the identification's unknowns)."""
        x = np.asarray(x, dtype=float)
        return cls(x[:3], x[3:6])

    @property
    def vector(self) -> np.ndarray:
        """``(D, L, H, α, β, δ)``, mm and rad."""
        return np.concatenate([self.position, self.angles])

    @property
    def rotation(self) -> np.ndarray:
        return euler_matrix(*self.angles)

    def to_tracker(self, points) -> np.ndarray:
        """Machine-frame points (..., 3) → tracker frame, ``Rᵀ(p − T)`` (eq. 2)."""
        return (np.asarray(points, dtype=float) - self.position) @ self.rotation

    def to_machine(self, points) -> np.ndarray:
        """Tracker-frame points (..., 3) → machine frame, ``R·p_LT + T``."""
        return np.asarray(points, dtype=float) @ self.rotation.T + self.position

    def jacobian(self, points) -> np.ndarray:
        """∂p_LT/∂(D, L, H, α, β, δ) of :meth:`to_tracker`, shape (..., 3, 6)."""
        p = np.asarray(points, dtype=float) - self.position
        rot = self.rotation
        d_rot = _euler_derivatives(self.angles)  # (3, 3, 3): [i, j, angle]
        # p_LT_j = Σ_i p_i R_ij
        d_ang = np.einsum("...i,ijk->...jk", p, d_rot)
        d_pos = np.broadcast_to(-rot.T, (*p.shape[:-1], 3, 3))
        return np.concatenate([d_pos, d_ang], axis=-1)

    def to_dict(self) -> dict:
        return {
            "D_mm": float(self.position[0]),
            "L_mm": float(self.position[1]),
            "H_mm": float(self.position[2]),
            "alpha_deg": float(self.angles[0] / _DEG),
            "beta_deg": float(self.angles[1] / _DEG),
            "delta_deg": float(self.angles[2] / _DEG),
        }

    @classmethod
    def from_dict(cls, doc: dict, source: str = "pose") -> TrackerPose:
        keys = ("D_mm", "L_mm", "H_mm", "alpha_deg", "beta_deg", "delta_deg")
        missing = [k for k in keys if k not in doc]
        if missing:
            raise InputError(f"{source}: missing field(s) {', '.join(missing)}")
        values = []
        for k in keys:
            try:
                v = float(doc[k])
            except (TypeError, ValueError):
                raise InputError(f"{source}: field {k} must be a number, got {doc[k]!r}") from None
            if not np.isfinite(v):
                raise InputError(f"{source}: field {k} must be finite, got {v}")
            values.append(v)
        return cls.from_customary(*values)


def spherical(points_tracker) -> np.ndarray:
    """Range, azimuth, elevation (..., 3) in mm and rad of tracker-frame points.

    ``a = atan2(y, x)`` in (−π, π], ``e = asin(z/r)``.
    """
    p = np.asarray(points_tracker, dtype=float)
    r = np.linalg.norm(p, axis=-1)
    az = np.arctan2(p[..., 1], p[..., 0])
    el = np.arcsin(np.clip(p[..., 2] / np.where(r > 0, r, 1.0), -1.0, 1.0))
    return np.stack([r, az, el], axis=-1)


def cartesian(readings) -> np.ndarray:
    """Tracker-frame points (..., 3) from (range, azimuth, elevation), mm and rad."""
    s = np.asarray(readings, dtype=float)
    r, az, el = s[..., 0], s[..., 1], s[..., 2]
    ce = np.cos(el)
    return np.stack([r * ce * np.cos(az), r * ce * np.sin(az), r * np.sin(el)], axis=-1)


def spherical_jacobian(readings) -> np.ndarray:
    """∂(x, y, z)/∂(r, a, e) of :func:`cartesian`, shape (..., 3, 3)."""
    s = np.asarray(readings, dtype=float)
    r, az, el = s[..., 0], s[..., 1], s[..., 2]
    ca, sa, ce, se = np.cos(az), np.sin(az), np.cos(el), np.sin(el)
    rows = [
        [ce * ca, -r * ce * sa, -r * se * ca],
        [ce * sa, r * ce * ca, -r * se * sa],
        [se, np.zeros_like(r), r * ce],
    ]
    return np.stack([np.stack(row, axis=-1) for row in rows], axis=-2)


@dataclass(frozen=True)
class TrackerNoise:
    """Noise of a tracker reading (Aguado et al. (2019), Section 3).

    Attributes
    ----------
    u_range_constant : float
        Constant part of the range uncertainty, mm (4 µm).
    u_range_per_length : float
        Length-proportional part, dimensionless (0.8 µm/m); ``u_r = u_r0 + k·r``.
    u_angle : float
        Standard deviation of each angle reading (azimuth and elevation), rad (20 µrad):
        the mean level when ``u_angle_spread > 0``.
    u_angle_spread : float
        Standard deviation of the level itself, rad (3 µrad: the paper draws u_θ and u_φ
        from N(20, 3) µrad).  The first-order covariance uses the effective level
        ``√(u_angle² + u_angle_spread²)`` (the variance of a reading whose level is random).
    level_draw : str
        When the level is drawn: ``"test"`` (once per simulated verification, the paper's
        "each test gets different point uncertainties", the default) or ``"point"``.
    u_smr : float
        Isotropic SMR-centring standard uncertainty, mm (0: the paper gives no value).
    """

    u_range_constant: float = 4.0 * _UM
    u_range_per_length: float = 0.8 * _UM_PER_M
    u_angle: float = 20.0 * _URAD
    u_angle_spread: float = 3.0 * _URAD
    level_draw: str = "test"
    u_smr: float = 0.0

    def __post_init__(self):
        for name in (
            "u_range_constant",
            "u_range_per_length",
            "u_angle",
            "u_angle_spread",
            "u_smr",
        ):
            v = float(getattr(self, name))
            if not np.isfinite(v) or v < 0:
                raise InputError(f"tracker noise: {name} must be finite and >= 0, got {v}")
            object.__setattr__(self, name, v)
        if self.level_draw not in ("test", "point"):
            raise InputError(
                f"tracker noise: level_draw must be 'test' or 'point', got {self.level_draw!r}"
            )

    @property
    def u_angle_effective(self) -> float:
        return float(np.hypot(self.u_angle, self.u_angle_spread))

    def u_range(self, r) -> np.ndarray:
        return self.u_range_constant + self.u_range_per_length * np.asarray(r, dtype=float)

    def sample_readings(self, rng: np.random.Generator, readings: np.ndarray) -> np.ndarray:
        """Noisy copies of exact readings (..., n_points, 3): the leading axes are tests.

        The angular level is drawn from N(u_angle, u_angle_spread) once per test (all
        leading indices) or once per point, then clipped at 0.
        """
        s = np.asarray(readings, dtype=float)
        level_shape = s.shape[:-2] + ((1,) if self.level_draw == "test" else s.shape[-2:-1])
        level = np.maximum(rng.normal(self.u_angle, self.u_angle_spread, level_shape), 0.0)
        z = rng.standard_normal(s.shape)
        out = s.copy()
        out[..., 0] += self.u_range(s[..., 0]) * z[..., 0]
        out[..., 1] += level * z[..., 1]
        out[..., 2] += level * z[..., 2]
        return out

    def sample_smr(self, rng: np.random.Generator, shape) -> np.ndarray:
        """SMR-centring errors, tracker frame, shape (*shape, 3)."""
        return self.u_smr * rng.standard_normal((*shape, 3))

    def to_dict(self) -> dict:
        return {
            "u_range_constant_um": self.u_range_constant / _UM,
            "u_range_per_length_um_per_m": self.u_range_per_length / _UM_PER_M,
            "u_angle_urad": self.u_angle / _URAD,
            "u_angle_spread_urad": self.u_angle_spread / _URAD,
            "level_draw": self.level_draw,
            "u_smr_um": self.u_smr / _UM,
        }

    @classmethod
    def from_dict(cls, doc: dict) -> TrackerNoise:
        return cls(
            doc["u_range_constant_um"] * _UM,
            doc["u_range_per_length_um_per_m"] * _UM_PER_M,
            doc["u_angle_urad"] * _URAD,
            doc["u_angle_spread_urad"] * _URAD,
            doc["level_draw"],
            doc["u_smr_um"] * _UM,
        )


def point_covariance(points_tracker, noise: TrackerNoise, *, effective: bool = True) -> np.ndarray:
    """First-order covariance of tracker-frame points, shape (..., 3, 3), mm².

    ``J·diag(u_r², u_a², u_e²)·Jᵀ + u_SMR²·I`` with J from :func:`spherical_jacobian`;
    ``effective`` uses the level ``√(u_angle² + spread²)``, otherwise ``u_angle``.
    """
    s = spherical(points_tracker)
    jac = spherical_jacobian(s)
    u_ang = noise.u_angle_effective if effective else noise.u_angle
    var = np.stack(
        [
            noise.u_range(s[..., 0]) ** 2,
            np.full(s.shape[:-1], u_ang**2),
            np.full(s.shape[:-1], u_ang**2),
        ],
        axis=-1,
    )
    cov = np.einsum("...ik,...k,...jk->...ij", jac, var, jac)
    return cov + noise.u_smr**2 * np.eye(3)


def eq23_variances(points_tracker, noise: TrackerNoise, *, effective: bool = True) -> np.ndarray:
    """The paper's per-axis variances (eq. 23), shape (..., 3), mm², written as printed.

    θ is the polar angle (90° − elevation), φ the azimuth; the result equals the diagonal
    of :func:`point_covariance` without the SMR term.
    """
    s = spherical(points_tracker)
    r, phi, theta = s[..., 0], s[..., 1], np.pi / 2 - s[..., 2]
    u_ang = noise.u_angle_effective if effective else noise.u_angle
    ur2, ut2, up2 = noise.u_range(r) ** 2, u_ang**2, u_ang**2
    st, ct, sp, cp = np.sin(theta), np.cos(theta), np.sin(phi), np.cos(phi)
    ux2 = st**2 * cp**2 * ur2 + r**2 * ct**2 * cp**2 * ut2 + r**2 * st**2 * sp**2 * up2
    uy2 = st**2 * sp**2 * ur2 + r**2 * ct**2 * sp**2 * ut2 + r**2 * st**2 * cp**2 * up2
    uz2 = ct**2 * ur2 + r**2 * st**2 * ut2
    return np.stack([ux2, uy2, uz2], axis=-1)


@dataclass(frozen=True)
class TrackerLimits:
    """Measuring range of a tracker (Aguado et al. (2019), Section 3).

    Attributes
    ----------
    range_min, range_max : float
        mm (0.5 m and 15 m).
    elevation_max : float
        |elevation| limit, rad (45°).
    azimuth_max : float
        |azimuth| limit, rad (235°).
    """

    range_min: float = 500.0
    range_max: float = 15_000.0
    elevation_max: float = 45.0 * _DEG
    azimuth_max: float = 235.0 * _DEG

    def within(self, readings) -> np.ndarray:
        """Boolean mask (...) of readings (range, azimuth, elevation) inside the limits."""
        s = np.asarray(readings, dtype=float)
        return (
            (s[..., 0] >= self.range_min)
            & (s[..., 0] <= self.range_max)
            & (np.abs(s[..., 2]) <= self.elevation_max)
            & (np.abs(s[..., 1]) <= self.azimuth_max)
        )

    def check(self, readings, what: str = "mesh point", where=None) -> None:
        """Raise :class:`InputError` naming the first reading outside the limits: ``what``
        and its number, or ``where(i)`` (a file and line) when given."""
        s = np.asarray(readings, dtype=float).reshape(-1, 3)
        bad = np.flatnonzero(~self.within(s))
        if bad.size == 0:
            return
        i = int(bad[0])
        r, az, el = s[i]
        if not self.range_min <= r <= self.range_max:
            r_m, lo, hi = (
                float(from_internal(v, "m")) for v in (r, self.range_min, self.range_max)
            )
            why = f"range {r_m:.3f} m outside {lo:g}–{hi:g} m"
        elif abs(el) > self.elevation_max:
            why = f"elevation {el / _DEG:.2f}° beyond ±{self.elevation_max / _DEG:g}°"
        else:
            why = f"azimuth {az / _DEG:.2f}° beyond ±{self.azimuth_max / _DEG:g}°"
        place = f"{what} {i + 1}" if where is None else where(i)
        raise InputError(f"{place}: {why} of the tracker")


def perturb_pose(
    pose: TrackerPose, rng: np.random.Generator, u_position: float, u_rotation: float, size: int
) -> np.ndarray:
    """Registration errors of eqs 25–26 on the rotation group: (size, 6) pose vectors.

    ``T' = T + N(0, u_position²·I)``, ``R' = R·exp([ω]×)`` with ``ω ~ N(0, u_rotation²·I)``
    (a small rotation about the tracker's axes), returned as (D, L, H, α, β, δ).  Adding a
    random matrix to R (eq. 25 as printed) would leave it non-orthonormal.
    """
    w = u_rotation * rng.standard_normal((size, 3))
    angle = np.linalg.norm(w, axis=1)
    k = w / np.where(angle > 0, angle, 1.0)[:, None]
    kx = np.zeros((size, 3, 3))
    kx[:, 0, 1], kx[:, 0, 2], kx[:, 1, 2] = -k[:, 2], k[:, 1], -k[:, 0]
    kx = kx - np.swapaxes(kx, 1, 2)
    s, c = np.sin(angle)[:, None, None], np.cos(angle)[:, None, None]
    exp_w = np.eye(3) + s * kx + (1 - c) * (kx @ kx)  # Rodrigues
    rot = pose.rotation @ exp_w
    t = pose.position + u_position * rng.standard_normal((size, 3))
    return np.concatenate([t, euler_angles(rot)], axis=1)
