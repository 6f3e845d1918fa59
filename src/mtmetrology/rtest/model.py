"""The static R-test as observations of the kinematic chain (ISO 10791-6 style).

A precision sphere is fixed on the table; a nest of three (or four) displacement sensors
in the spindle touches it.  At each indexation k of the rotary axes the linear axes are
commanded so that the nest centre (the machine's tool point) nominally coincides with
the sphere centre, and the sensors read the sphere's displacement relative to the nest.

Measurement model of sensor j at indexation k::

    s_jk = g_j · n_jᵀ R_kᵀ (d − p(q_k; θ)) + z_j                          (1)

``n_j``
    the sensor's measuring direction, a unit vector in the tool (spindle) frame: the
    reading grows when the sphere centre moves along +n_j relative to the nest;
``g_j``
    its gain (reading per displacement, 1 for a calibrated sensor);
``R_k``
    the nominal orientation of the tool frame in the workpiece frame at q_k, from the
    chain (∂p/∂t of :meth:`~mtmetrology.kinematics.Machine.evaluate`); the errors rotate
    the sensed displacement only at second order;
``p(q_k; θ)``
    the nest centre of the kinematic chain with the ISO 230-1 parameters θ (no second copy
    of the kinematics);
``d``
    the sphere centre in the workpiece frame (nuisance unknowns ``sphere x|y|z``);
``z_j``
    the sensor's zero (``sensor <j> zero``, nuisance): the readings are relative to an
    arbitrary setting; with three sensors the zeros are the nest's offset from the tool
    point.

Residuals are ``(s_model − s)/σ``; the Jacobian is analytic: ∂s/∂θ = −g n_jᵀ R_kᵀ ∂p/∂θ,
∂s/∂d = g n_jᵀ R_kᵀ, ∂s/∂z_j = 1.  What a programme can identify is decided by rank
(:func:`mtmetrology.identification.choose_datum`), as for SAMBA: e.g. a constant shift of
the outermost rotary axis line (``E_X0B``) moves the sphere by the same vector in the
tool frame at every indexation, which the sensor zeros absorb.

References
----------
ISO 10791-6:2014, *Test conditions for machining centres — Part 6: Accuracy of speeds and
interpolations*, Annex (R-test of the rotary axes); S. Ibaraki, C. Oyama, H. Otsubo,
"Construction of an error map of rotary axes on a five-axis machining center by static
R-test", *Int. J. Mach. Tools Manuf.* 51 (2011) 190–200; ISO 230-1:2012, §3 (location
errors).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameters import catalogue
from mtmetrology.kinematics.topology import LINEAR_AXES

__all__ = ["RTestProblem", "Sensors", "indexations", "rotary_location_candidates"]


@dataclass(frozen=True)
class Sensors:
    """The nest's displacement sensors.

    Attributes
    ----------
    directions : (k, 3) ndarray
        Unit measuring directions in the tool frame (k = 3 or 4; they must span 3-D).
    gains : (k,) ndarray
        Reading per displacement (1 for calibrated sensors).
    """

    directions: np.ndarray = field(default_factory=lambda: np.eye(3))
    gains: np.ndarray = field(default_factory=lambda: np.ones(3))

    def __post_init__(self):
        n = np.asarray(self.directions, dtype=float)
        g = np.asarray(self.gains, dtype=float)
        if n.ndim != 2 or n.shape[1] != 3 or n.shape[0] not in (3, 4):
            raise InputError(f"sensor directions: 3 or 4 vectors of 3 components, got {n.shape}")
        if g.shape != (n.shape[0],) or not np.all(np.isfinite(g) & (g > 0)):
            raise InputError(f"sensor gains: {n.shape[0]} positive numbers, got {g.tolist()}")
        lengths = np.linalg.norm(n, axis=1)
        if np.any(lengths == 0) or not np.all(np.isfinite(lengths)):
            raise InputError("a sensor direction is zero or not finite")
        n = n / lengths[:, None]
        if np.linalg.matrix_rank(n, tol=1e-6) < 3:
            raise InputError(
                "the sensor directions do not span 3-D: the nest cannot see the sphere"
            )
        object.__setattr__(self, "directions", n)
        object.__setattr__(self, "gains", g)

    @property
    def count(self) -> int:
        return int(self.directions.shape[0])

    def to_dict(self) -> dict:
        return {
            "directions_tool_frame": self.directions.tolist(),
            "gains": self.gains.tolist(),
            "sign": "a reading grows when the sphere centre moves along +direction relative "
            "to the nest",
        }


def rotary_location_candidates(machine: Machine) -> list[str]:
    """Location errors of the rotary axes other than those along or about the axis itself
    (``E_X0C``, ``E_Y0C``, ``E_A0C``, ``E_B0C`` for C about Z; the spindle S excluded)."""
    out = []
    for p in catalogue(machine.topology, 0):
        if p.kind != "location" or p.axis in LINEAR_AXES or p.axis == "S":
            continue
        own = int(np.argmax(np.abs(machine.axes[p.axis].direction)))
        if p.component % 3 != own:
            out.append(p.name)
    return out


def indexations(machine: Machine, centre, rotary: np.ndarray, *, params=None) -> np.ndarray:
    """Readings (n, n_axes) that put the nest at the sphere's nominal centre for each row of
    rotary readings (n, n_rotary; rad), by the machine's inverse kinematics."""
    rot = [i for i, a in enumerate(machine.axis_names) if a not in LINEAR_AXES]
    r = np.atleast_2d(np.asarray(rotary, dtype=float))
    if r.shape[1] != len(rot):
        raise InputError(
            f"{r.shape[1]} rotary readings per indexation; {machine.name} has "
            f"{', '.join(machine.axis_names[i] for i in rot)}"
        )
    start = np.zeros((r.shape[0], machine.n_axes))
    start[:, rot] = r
    return machine.inverse(np.broadcast_to(centre, (r.shape[0], 3)), start, params)


class RTestProblem:
    """Weighted least squares of R-test sensor readings (model (1) of the module notes).

    Parameters
    ----------
    machine : Machine
        Its active parameters are the unknowns.
    readings : (n, n_axes) ndarray
        Axis readings of each indexation (mm, rad).
    sensed : (n, k) ndarray
        Sensor readings, mm.
    sensors : Sensors
    sigma : float
        Standard uncertainty of one sensor reading, mm.
    sphere : (3,) array_like
        Nominal sphere centre (starting value), workpiece frame, mm.
    """

    def __init__(self, machine: Machine, readings, sensed, sensors: Sensors, *, sigma, sphere):
        q = np.asarray(readings, dtype=float)
        s = np.asarray(sensed, dtype=float)
        if q.ndim != 2 or q.shape[1] != machine.n_axes:
            raise InputError(f"readings must be (n, {machine.n_axes})")
        if s.shape != (q.shape[0], sensors.count):
            raise InputError(
                f"{s.shape} sensor readings for {q.shape[0]} indexations of {sensors.count} sensors"
            )
        if not (np.isfinite(sigma) and sigma > 0):
            raise InputError(f"sigma must be positive, got {sigma}")
        self.machine = machine
        self.readings = q
        self.sensed = s
        self.sensors = sensors
        self.sigma = float(sigma)
        self.sphere0 = np.asarray(sphere, dtype=float)
        rotation = machine.evaluate(q, d_tool=True).d_tool  # (n, 3, 3), nominal
        # g_j n_jᵀ R_kᵀ: (n, k, 3), the sensed component of a workpiece-frame displacement
        self.projection = sensors.gains[None, :, None] * np.einsum(
            "jc,kwc->kjw", sensors.directions, rotation
        )
        self.nuisance = [f"sphere {c}" for c in "xyz"] + [
            f"sensor {j + 1} zero" for j in range(sensors.count)
        ]
        self.names = (*machine.parameter_names, *self.nuisance)
        self.n_rows = int(s.size)

    def initial(self) -> np.ndarray:
        x = np.zeros(len(self.names))
        x[self.machine.n_params : self.machine.n_params + 3] = self.sphere0
        return x

    def model(self, x: np.ndarray, *, jacobian: bool = False):
        """Sensor readings (..., n·k) at unknowns x (..., n_unknowns); with ``jacobian``
        (single x) also their Jacobian."""
        x = np.asarray(x, dtype=float)
        n_p = self.machine.n_params
        theta, sphere, zero = x[..., :n_p], x[..., n_p : n_p + 3], x[..., n_p + 3 :]
        ev = self.machine.evaluate(self.readings, theta[..., None, :], d_params=jacobian)
        gap = sphere[..., None, :] - ev.position  # (..., n, 3)
        s = np.einsum("kjw,...kw->...kj", self.projection, gap) + zero[..., None, :]
        s = s.reshape(*s.shape[:-2], -1)
        if not jacobian:
            return s
        n, k = self.sensed.shape
        jac = np.zeros((n, k, len(self.names)))
        jac[:, :, :n_p] = -np.einsum("kjw,kwp->kjp", self.projection, ev.d_params)
        jac[:, :, n_p : n_p + 3] = self.projection
        jac[:, :, n_p + 3 :] = np.eye(k)[None]
        return s, jac.reshape(n * k, -1)

    def evaluate(self, x: np.ndarray, jacobian: bool = True):
        """Weighted residuals and Jacobian (the identification engine's protocol)."""
        s, jac = self.model(x, jacobian=True)
        r = (s - self.sensed.ravel()) / self.sigma
        return (r, jac / self.sigma) if jacobian else r

    def residuals_batch(self, x: np.ndarray, sensed: np.ndarray) -> np.ndarray:
        """Weighted residuals of K problems with readings ``sensed`` (K, n·k) at x (K, n_u)."""
        return (self.model(x) - sensed) / self.sigma
