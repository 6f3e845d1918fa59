"""The set-up of a laser-tracker verification: mesh, tool offsets, pose, machine conditions.

Inputs are checked once here, at the door: a mesh outside the travels, a NaN, a tracker
inside the workspace or seeing a point beyond its limits is refused with one line naming
the field.

Machine conditions (Aguado et al. (2019), eqs 3, 7–17) act on the commanded coordinate of
each axis q ∈ {x, y, z}::

    q_eff = (q + s·B_q/2 + e_q)·(1 + α_q·(T_q(q) − 20 °C))

with ``s = ±1`` the sense of approach and ``B_q`` the reversal value (ISO 230-2; the
paper's "backlash" β_q, a constant there: its sense dependence is made explicit here),
``e_q ~ N(0, σ_q²)`` the repeatability and control noise (eqs 15–17), ``α_q`` the CTE of
the axis scale and ``T_q(q)`` the axis temperature interpolated linearly between the two
sensors at the ends of its travel.  The CTE uncertainty follows eq. 10: a rectangular full
width of max(10 % of α, 0.002 µm/(mm·K)), ``u(α) = 0.002/(2√3) = 5.77 × 10⁻⁴ µm/(mm·K)``
for steel (the paper prints 0.0006); a sensor's standard uncertainty is ``U/k`` of its
certificate (eq. 3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.io.plausibility import check_expansion_coefficient, check_temperatures
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.tracker import TrackerLimits, TrackerPose, spherical
from mtmetrology.units import to_internal

__all__ = [
    "PAPER_POSE",
    "MachineConditions",
    "check_pose",
    "cte_uncertainty",
    "measurement_points",
    "parse_mesh",
]

#: 1 µm/(m·K) in 1/K (a CTE is a strain per kelvin)
_UM_PER_MK = float(to_internal(1.0, "µm/m"))
#: Study 2 pose of Aguado et al. (2019), Section 3.
PAPER_POSE = TrackerPose.from_customary(-563.52, 194.37, 677.78, 0.0339, 0.0343, 59.4652)


def cte_uncertainty(alpha: float) -> float:
    """Standard uncertainty of a CTE, 1/K (Aguado et al. (2019), eq. 10).

    Rectangular of full width ``max(0.1·α, 2e-6 /K)`` (0.002 µm/(mm·K)):
    ``u = width/(2√3)``.

    Examples
    --------
    Steel, α = 11.5 µm/(m·K): the floor applies, u = 0.002/(2√3) = 5.77e-4 µm/(mm·K)

    >>> from mtmetrology.units import from_internal
    >>> round(float(from_internal(cte_uncertainty(11.5e-6), "µm/mm")), 7)  # µm/(mm·K)
    0.0005774
    """
    width = max(0.1 * abs(alpha), 2.0 * _UM_PER_MK)
    return width / (2.0 * math.sqrt(3.0))


def parse_mesh(spec: str, machine: Machine) -> np.ndarray:
    """Mesh points (n, 3) in mm from ``"x0:x1:step,y0:y1:step,z0:z1:step"`` (ends included).

    Points are ordered X fastest, then Y, then Z (the order of measurement).
    """
    parts = [p.strip() for p in str(spec).split(",")]
    if len(parts) != 3:
        raise InputError(f"--mesh {spec!r}: give three ranges start:stop:step for X, Y, Z")
    axes = []
    for axis, part in zip("XYZ", parts, strict=True):
        try:
            start, stop, step = (float(v) for v in part.split(":"))
        except ValueError:
            raise InputError(f"--mesh: {axis} range {part!r} is not start:stop:step") from None
        if not all(map(math.isfinite, (start, stop, step))) or step <= 0 or stop < start:
            raise InputError(f"--mesh: {axis} range {part!r} needs finite start <= stop, step > 0")
        n = math.floor((stop - start) / step + 1e-9) + 1
        axes.append(start + step * np.arange(n))
    z, y, x = np.meshgrid(axes[2], axes[1], axes[0], indexing="ij")
    mesh = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    for i, a in enumerate("XYZ"):
        lo, hi = machine.axes[a].travel
        bad = np.flatnonzero((mesh[:, i] < lo - 1e-9) | (mesh[:, i] > hi + 1e-9))
        if bad.size:
            raise InputError(
                f"--mesh: {a} = {mesh[bad[0], i]:g} mm lies outside the travel of "
                f"{machine.name} [{lo:g}, {hi:g}] mm"
            )
    return mesh


def measurement_points(mesh: np.ndarray, tools: np.ndarray):
    """Every mesh point with every tool offset: readings (n·n_t, 3), tools (n·n_t, 3)."""
    tools = np.atleast_2d(np.asarray(tools, dtype=float))
    if tools.shape[1] != 3 or not np.all(np.isfinite(tools)):
        raise InputError("tools: each tool offset must be three finite numbers (mm)")
    return np.repeat(mesh, len(tools), axis=0), np.tile(tools, (len(mesh), 1))


def workspace_box(machine: Machine) -> np.ndarray:
    """(2, 3) lower and upper corners of the travels, mm (the region the tracker may not
    occupy)."""
    return np.array([machine.axes[a].travel for a in "XYZ"], dtype=float).T


def check_pose(
    pose: TrackerPose, machine: Machine, points: np.ndarray, limits: TrackerLimits
) -> None:
    """Refuse a tracker inside the workspace or seeing a point beyond its limits."""
    box = workspace_box(machine)
    if np.all(pose.position >= box[0]) and np.all(pose.position <= box[1]):
        d, l, h = pose.position
        raise InputError(
            f"pose: the tracker at D, L, H = {d:g}, {l:g}, {h:g} mm lies inside the workspace "
            f"of {machine.name}"
        )
    limits.check(spherical(pose.to_tracker(points)), "measurement point")


@dataclass(frozen=True)
class MachineConditions:
    """Temperatures, CTEs, reversal and repeatability of the three axes (module notes).

    Attributes
    ----------
    sensor_temperatures : (3, 2) ndarray
        Per axis X, Y, Z the readings of the sensors at the lower and upper end of its
        travel, °C (20: no thermal effect).
    u_sensor : float
        Standard uncertainty of a sensor, K (U/k of its certificate, eq. 3).
    cte : (3,) ndarray
        Nominal CTE of each axis scale, 1/K (steel: 11.5e-6).
    u_cte : (3,) ndarray
        Their standard uncertainties, 1/K (eq. 10 by default).
    reversal : (3,) ndarray
        Reversal value B of each axis, mm; a positive value puts the axis B/2 further along
        its travel when approached in the positive sense.
    repeatability : (3,) ndarray
        Standard deviation of the positioning repeatability and control noise, mm.
    geometric_random : float
        Relative standard deviation of the random part of every geometric error
        (eqs 18–20): each parameter θ_j gets ``u_j = geometric_random·|θ_j|``.
    geometric_distribution : str
        ``"normal"`` or ``"beta"`` (symmetric Beta(2, 2) on ±√5·u_j, same u_j).
    """

    sensor_temperatures: np.ndarray = field(default_factory=lambda: np.full((3, 2), 20.0))
    u_sensor: float = 0.05
    cte: np.ndarray = field(default_factory=lambda: np.full(3, 11.5e-6))
    u_cte: np.ndarray | None = None
    reversal: np.ndarray = field(default_factory=lambda: np.zeros(3))
    repeatability: np.ndarray = field(default_factory=lambda: np.zeros(3))
    geometric_random: float = 0.0
    geometric_distribution: str = "normal"

    def __post_init__(self):
        shapes = {"sensor_temperatures": (3, 2), "cte": (3,), "reversal": (3,)}
        shapes["repeatability"] = (3,)
        for name, shape in shapes.items():
            v = np.asarray(getattr(self, name), dtype=float)
            if v.shape != shape or not np.all(np.isfinite(v)):
                raise InputError(f"conditions: {name} must be {shape} finite numbers, got {v}")
            object.__setattr__(self, name, v)
        check_temperatures(self.sensor_temperatures, "conditions: sensor_temperatures_C")
        check_expansion_coefficient(self.cte, "conditions: cte_per_K")
        if self.u_cte is None:
            object.__setattr__(self, "u_cte", np.array([cte_uncertainty(a) for a in self.cte]))
        u = np.asarray(self.u_cte, dtype=float)
        if u.shape != (3,) or not np.all(np.isfinite(u)) or np.any(u < 0):
            raise InputError(f"conditions: u_cte must be three finite numbers >= 0, got {u}")
        object.__setattr__(self, "u_cte", u)
        for name in ("u_sensor", "geometric_random"):
            v = float(getattr(self, name))
            if not math.isfinite(v) or v < 0:
                raise InputError(f"conditions: {name} must be finite and >= 0, got {v}")
            object.__setattr__(self, name, v)
        if np.any(self.repeatability < 0):
            raise InputError("conditions: repeatability must be >= 0")
        if self.geometric_distribution not in ("normal", "beta"):
            raise InputError(
                "conditions: geometric_distribution must be 'normal' or 'beta', got "
                f"{self.geometric_distribution!r}"
            )

    def temperatures(self, machine: Machine, readings: np.ndarray) -> np.ndarray:
        """Axis temperatures (..., 3), °C, interpolated between the sensors of each axis."""
        q = np.asarray(readings, dtype=float)
        out = np.empty(q.shape)
        for i, a in enumerate("XYZ"):
            lo, hi = machine.axes[a].travel
            f = (q[..., i] - lo) / (hi - lo)
            t0, t1 = self.sensor_temperatures[i]
            out[..., i] = t0 + (t1 - t0) * f
        return out

    def axis_variances(self, readings: np.ndarray, temperatures: np.ndarray) -> np.ndarray:
        """Variance (..., 3), mm², of each corrected axis coordinate: repeatability, CTE
        uncertainty times ``q·ΔT``, and sensor uncertainty times ``q·α``."""
        q = np.asarray(readings, dtype=float)
        dt = np.asarray(temperatures, dtype=float) - 20.0
        return (
            self.repeatability**2 + (q * dt * self.u_cte) ** 2 + (q * self.cte * self.u_sensor) ** 2
        )

    def to_dict(self) -> dict:
        return {
            "sensor_temperatures_C": self.sensor_temperatures.tolist(),
            "u_sensor_K": self.u_sensor,
            "cte_per_K": self.cte.tolist(),
            "u_cte_per_K": self.u_cte.tolist(),
            "reversal_mm": self.reversal.tolist(),
            "repeatability_mm": self.repeatability.tolist(),
            "geometric_random": self.geometric_random,
            "geometric_distribution": self.geometric_distribution,
        }

    @classmethod
    def from_dict(cls, doc: dict, source: str = "conditions") -> MachineConditions:
        """From the file form of :meth:`to_dict`; missing keys take their defaults
        (``u_cte_per_K``: eq. 10 of the CTEs), unknown keys are refused."""
        fields = {
            "sensor_temperatures_C": "sensor_temperatures",
            "u_sensor_K": "u_sensor",
            "cte_per_K": "cte",
            "u_cte_per_K": "u_cte",
            "reversal_mm": "reversal",
            "repeatability_mm": "repeatability",
            "geometric_random": "geometric_random",
            "geometric_distribution": "geometric_distribution",
        }
        unknown = sorted(set(doc) - set(fields) - {"kind", "version"})
        if unknown:
            raise InputError(f"{source}: {unknown[0]}: unknown key (known: {', '.join(fields)})")
        kwargs = {}
        for key, name in fields.items():
            if key not in doc:
                continue
            value = doc[key]
            if name != "geometric_distribution":
                try:
                    value = np.asarray(value, dtype=float)
                except (TypeError, ValueError):
                    raise InputError(f"{source}: {key}: must be numbers, got {value!r}") from None
            kwargs[name] = value
        try:
            return cls(**kwargs)
        except InputError as err:
            raise InputError(f"{source}: {str(err).removeprefix('conditions: ')}") from None
