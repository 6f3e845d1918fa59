"""Observation model of sequential multilateration with a tracking interferometer.

A tracking interferometer (LaserTRACER) at station j, centre S_j in the workpiece frame,
follows a reflector carried by the spindle at tool vector t_i.  It measures the change of
distance only, so every station has an unknown dead path ℓ0_j.  The length read when the
machine is at readings q_i is (Mutilba et al., seed 003, B2.3; Schwenke et al. 2005)::

    ℓ_ij = ‖p(q_i; θ, t_i) − S_j‖ − ℓ0_j + ε_ij,     u(ε_ij) = a + b·‖p − S_j‖

with p the kinematic engine's tool point (:meth:`Machine.evaluate`) and the instrument
specification U(k = 2) = 0.2 µm + 0.3 µm/m, i.e. a = 0.1 µm, b = 0.15 µm/m.  The
weighted residual and its analytic Jacobian, with n = (p − S_j)/‖p − S_j‖, are::

    r = (‖p − S_j‖ − ℓ0_j − ℓ_ij) / u_ij
    ∂r/∂θ = nᵀ ∂p/∂θ / u_ij,   ∂r/∂S_j = −nᵀ / u_ij,   ∂r/∂ℓ0_j = −1 / u_ij.

The unknowns are θ (the machine's active error parameters), then per station S_j (x, y, z)
and ℓ0_j.  The inputs (for propagation) are the lengths ℓ_ij.

References
----------
Schwenke, H., Franke, M., Hannaford, J., Kunzmann, H. (2005). Error mapping of CMMs and
machine tools by a single tracking interferometer. *CIRP Annals* 54(1), 475–478.
Mutilba, U. et al. (seed 003), Section 3 and digest B2.3 (sequential LaserTRACER).
"""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.units import parse_unit, to_internal

__all__ = ["LASERTRACER_SPEC", "LengthProblem", "length_uncertainty", "parse_spec"]

#: LaserTRACER NG spatial displacement specification U(k=2) = 0.2 µm + 0.3 µm/m, as the
#: standard uncertainty (a, b) of u = a + b·L: a in mm, b dimensionless.
LASERTRACER_SPEC = (float(to_internal(0.1, "µm")), float(to_internal(0.15, "µm/m")))


def parse_spec(text: str, *, parameter: str = "--noise") -> tuple[float, float]:
    """``"0.2um+0.3um/m"`` (an expanded uncertainty, k = 2) → standard (a mm, b).

    Raises
    ------
    InputError
        Not ``A<length unit>+B<length unit>/m``, or a negative term.
    """
    parts = str(text).replace(" ", "").split("+")
    if len(parts) != 2:
        raise InputError(f"{parameter}: expected A+B/m such as 0.2um+0.3um/m, got {text!r}")
    values = []
    for part, dim in zip(parts, ("length", "ratio"), strict=True):
        m = re.fullmatch(r"([0-9.eE-]+)(.*)", part)
        if m is None:
            raise InputError(f"{parameter}: cannot read {part!r} in {text!r}")
        try:
            x = float(to_internal(float(m.group(1)), m.group(2)))
        except ValueError:
            raise InputError(f"{parameter}: cannot read {part!r} in {text!r}") from None
        if parse_unit(m.group(2)).dimension != dim:
            raise InputError(f"{parameter}: {part!r} must be a {dim} (e.g. 0.2um+0.3um/m)")
        if not x >= 0:
            raise InputError(f"{parameter}: {part!r} must be >= 0")
        values.append(x / 2.0)
    return values[0], values[1]


def length_uncertainty(distance: np.ndarray, spec: tuple[float, float] = LASERTRACER_SPEC):
    """u(ℓ) = a + b·L of lengths at distances L (mm) from the station."""
    a, b = spec
    return a + b * np.asarray(distance, dtype=float)


class LengthProblem:
    """Weighted least squares of multilateration lengths (module notes).

    Parameters
    ----------
    machine : Machine
        Machine with its active error parameters (the identified unknowns).
    readings : (n, n_axes) ndarray
        Axis readings of every length (mm, rad).
    tools : (n, 3) ndarray
        Reflector (tool) vector of every length, mm.
    stations : sequence of str, length n
        Station id of every length.
    lengths : (n,) ndarray
        Measured lengths (mm, relative to each station's dead path).
    spec : (a, b)
        Standard uncertainty u = a + b·L of a length (mm, dimensionless).
    """

    def __init__(
        self,
        machine: Machine,
        readings: np.ndarray,
        tools: np.ndarray,
        stations: Sequence[str],
        lengths: np.ndarray,
        spec: tuple[float, float] = LASERTRACER_SPEC,
    ):
        q = np.asarray(readings, dtype=float)
        n = q.shape[0]
        if q.ndim != 2 or q.shape[1] != machine.n_axes:
            raise InputError(f"readings must be (n, {machine.n_axes})")
        self.machine = machine
        self.readings = q
        self.tools = np.broadcast_to(np.asarray(tools, dtype=float), (n, 3)).copy()
        ids = [str(s) for s in stations]
        self.station_ids = tuple(dict.fromkeys(ids))
        self.station_index = np.array([self.station_ids.index(s) for s in ids])
        self.lengths = np.asarray(lengths, dtype=float).ravel()
        if self.lengths.size != n or len(ids) != n:
            raise InputError(f"{n} readings, {len(ids)} station ids, {self.lengths.size} lengths")
        a, b = spec
        if not (a >= 0 and b >= 0 and a + b > 0):
            raise InputError(f"length uncertainty a + b·L: a, b must be >= 0, got {spec}")
        self.spec = (float(a), float(b))
        self.n_params = machine.n_params
        self.n_stations = len(self.station_ids)
        self.names = (
            *machine.parameter_names,
            *(f"station {s} {c}" for s in self.station_ids for c in ("x", "y", "z", "l0")),
        )
        self._u = None

    @property
    def n_rows(self) -> int:
        return self.lengths.size

    @property
    def n_unknowns(self) -> int:
        return len(self.names)

    def split(self, x: np.ndarray):
        """(θ, station centres (n_stations, 3), dead paths (n_stations,))."""
        p = self.n_params
        block = np.asarray(x[p:], dtype=float).reshape(self.n_stations, 4)
        return x[:p], block[:, :3], block[:, 3]

    def sigma(self, x: np.ndarray | None = None) -> np.ndarray:
        """u(ℓ_ij) at the distances of the start (fixed once: the weights of the problem)."""
        if self._u is None:
            x = self.initial() if x is None else x
            theta, centres, _ = self.split(x)
            pos = self.machine.forward(self.readings, theta, tool=self.tools)
            dist = np.linalg.norm(pos - centres[self.station_index], axis=1)
            self._u = length_uncertainty(dist, self.spec)
        return self._u

    @property
    def residual_rounding(self) -> float:
        size = max(float(np.abs(self.lengths).max(initial=0.0)), 1000.0)
        return float(np.finfo(float).eps) * size / float(self.sigma().min())

    def initial(self) -> np.ndarray:
        """Zero errors; each station and dead path by the linear closed form.

        (ℓ + ℓ0)² = ‖p − S‖² is linear in (S, ℓ0, ℓ0² − ‖S‖²):
        ‖p‖² − ℓ² = 2 pᵀS + 2 ℓ ℓ0 + (ℓ0² − ‖S‖²), solved by least squares per station
        on the nominal tool points (needs points that are not coplanar).
        """
        pos = self.machine.forward(self.readings, tool=self.tools)
        parts = [np.zeros(self.n_params)]
        for j in range(self.n_stations):
            sel = self.station_index == j
            p, ell = pos[sel], self.lengths[sel]
            a = np.column_stack([2 * p, 2 * ell, np.ones(ell.size)])
            rhs = np.einsum("ij,ij->i", p, p) - ell**2
            sol = np.linalg.lstsq(a, rhs, rcond=None)[0]
            parts.append(sol[:4])
        return np.concatenate(parts)

    def evaluate(self, x: np.ndarray, jacobian: bool = True):
        """Weighted residuals (n,) and their Jacobian (n, n_unknowns)."""
        x = np.asarray(x, dtype=float)
        theta, centres, dead = self.split(x)
        ev = self.machine.evaluate(self.readings, theta, tool=self.tools, d_params=jacobian)
        diff = ev.position - centres[self.station_index]
        dist = np.linalg.norm(diff, axis=1)
        u = self.sigma()
        r = (dist - dead[self.station_index] - self.lengths) / u
        if not jacobian:
            return r, None
        unit = diff / dist[:, None]
        jac = np.zeros((self.n_rows, self.n_unknowns))
        jac[:, : self.n_params] = np.einsum("nc,ncp->np", unit, ev.d_params) / u[:, None]
        cols = self.n_params + 4 * self.station_index
        rows = np.arange(self.n_rows)
        for c in range(3):
            jac[rows, cols + c] = -unit[:, c] / u
        jac[rows, cols + 3] = -1.0 / u
        return r, jac
