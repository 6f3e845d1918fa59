"""Simulated tracker measurements of a machine with known errors (Aguado et al. (2019), §2–3).

One simulated verification: the machine, with true error parameters θ (plus their random
parts, eqs 18–20), moves to every mesh point with every tool offset; each axis lands at
``q_eff`` (reversal, repeatability, thermal expansion with the true CTE and temperature,
:mod:`mtmetrology.tracker.setup`); the tracker at its pose reads range, azimuth and
elevation of the tool tip with its noise (:class:`~mtmetrology.kinematics.tracker.TrackerNoise`)
and the SMR error; the axis temperatures recorded are those of the sensors, with their
calibration error.

MEASUREMENTS CSV (what :func:`read_measurements` reads and ``mtm tracker calibrate``
takes)::

    point,X,Y,Z,tool_x,tool_y,tool_z,range,azimuth,elevation,T_X,T_Y,T_Z

commanded readings and tool offsets in mm, range in mm, azimuth and elevation in degrees,
axis temperatures in °C.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.identification.observations import senses_from_sequence
from mtmetrology.io.files import atomic_write
from mtmetrology.io.plausibility import check_temperatures, check_within
from mtmetrology.io.tables import read_csv_table, write_columns
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.tracker import (
    TrackerLimits,
    TrackerNoise,
    TrackerPose,
    cartesian,
    spherical,
)
from mtmetrology.rng import SeedLike, as_generator
from mtmetrology.tracker.setup import MachineConditions, check_pose, measurement_points
from mtmetrology.uncertainty.distributions import Beta
from mtmetrology.units import from_internal, to_internal

__all__ = ["TrackerMeasurements", "read_measurements", "simulate"]

COLUMNS = ("point", "X", "Y", "Z", "tool_x", "tool_y", "tool_z", "range", "azimuth",
           "elevation", "T_X", "T_Y", "T_Z")  # fmt: skip


@dataclass(frozen=True, eq=False)
class TrackerMeasurements:
    """Tracker readings of a verification.

    Attributes
    ----------
    readings : (n, 3) ndarray
        Commanded X, Y, Z, mm.
    tools : (n, 3) ndarray
        Tool offsets, mm.
    spherical : (n, 3) ndarray
        Range (mm), azimuth, elevation (rad).
    temperatures : (n, 3) ndarray
        Recorded axis temperatures, °C.
    provenance : dict
        How they were made (machine, pose, seed, noise, conditions of a simulation).
    """

    readings: np.ndarray
    tools: np.ndarray
    spherical: np.ndarray
    temperatures: np.ndarray
    provenance: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.readings)

    def to_dict(self) -> dict:
        return {
            "kind": "tracker-measurements",
            "version": 1,
            "readings_mm": self.readings.tolist(),
            "tools_mm": self.tools.tolist(),
            "range_mm": self.spherical[:, 0].tolist(),
            "azimuth_deg": from_internal(self.spherical[:, 1], "°").tolist(),
            "elevation_deg": from_internal(self.spherical[:, 2], "°").tolist(),
            "temperatures_C": self.temperatures.tolist(),
            "provenance": self.provenance,
        }

    @classmethod
    def from_dict(cls, doc: dict) -> TrackerMeasurements:
        sph = np.column_stack(
            [
                doc["range_mm"],
                to_internal(np.asarray(doc["azimuth_deg"]), "°"),
                to_internal(np.asarray(doc["elevation_deg"]), "°"),
            ]
        )
        return cls(
            np.asarray(doc["readings_mm"], float),
            np.asarray(doc["tools_mm"], float),
            sph,
            np.asarray(doc["temperatures_C"], float),
            dict(doc.get("provenance", {})),
        )

    def write(self, path: str | Path) -> None:
        """Write the MEASUREMENTS CSV atomically (module notes)."""
        cols = {"point": np.arange(1.0, len(self) + 1)}
        for i, a in enumerate("XYZ"):
            cols[a] = self.readings[:, i]
        for i, a in enumerate("xyz"):
            cols[f"tool_{a}"] = self.tools[:, i]
        cols["range"] = self.spherical[:, 0]
        cols["azimuth"] = from_internal(self.spherical[:, 1], "°")
        cols["elevation"] = from_internal(self.spherical[:, 2], "°")
        for i, a in enumerate("XYZ"):
            cols[f"T_{a}"] = self.temperatures[:, i]
        with atomic_write(path, "wb") as fh:
            write_columns(fh, cols, decimals=9)


def read_measurements(
    path: str | Path,
    tools: dict[str, np.ndarray] | None = None,
    machine: Machine | None = None,
) -> TrackerMeasurements:
    """Read a MEASUREMENTS CSV; a missing column, a non-number or NaN names file and line.

    Parameters
    ----------
    path : path-like
    tools : dict of str to (3,) array, optional
        Tool offsets (mm) by id (``mtm tracker calibrate --tool ID=x,y,z``): the rows of
        the file's ``tool`` column with that id take it, in place of their ``tool_x``,
        ``tool_y``, ``tool_z`` (which a file with a ``tool`` column may leave out).
    machine : Machine, optional
        The machine measured: its travels bound X, Y, Z, and the tracker points must be
        congruent with its nominal tool points (:func:`check_plausible`).

    Raises
    ------
    InputError
        A tool id with no offset (neither given nor in the file), tools given for a file
        without a ``tool`` column, a cell that is not a number, a temperature outside
        −50 to 100 °C, and with ``machine`` a position outside its travel or tracker
        readings that are not the positions commanded (angles in radians, a range in m).
    """
    by_id = dict(tools or {})
    fixed = [c for c in COLUMNS[1:] if not c.startswith("tool_")]
    table = read_csv_table(path, fixed, min_rows=4)
    has_xyz = table.has("tool_x") or not table.has("tool")  # else: a missing column, named
    col = {c: table.floats(c) for c in (COLUMNS[1:] if has_xyz else fixed)}
    sph = np.column_stack(
        [col["range"], to_internal(col["azimuth"], "°"), to_internal(col["elevation"], "°")]
    )
    readings = np.column_stack([col["X"], col["Y"], col["Z"]])
    temps = np.column_stack([col["T_X"], col["T_Y"], col["T_Z"]])
    if has_xyz:
        tool_rows = np.column_stack([col["tool_x"], col["tool_y"], col["tool_z"]])
    else:
        tool_rows = np.full((len(table), 3), np.nan)
    if table.has("tool"):
        for i, name in enumerate(table.strings("tool")):
            if name in by_id:
                tool_rows[i] = by_id[name]
            elif not has_xyz:
                raise InputError(
                    f"{path}, line {table.lines[i]}: tool {name!r} has no offset; give it "
                    f"with --tool {name}=x,y,z"
                )
        unused = sorted(set(by_id) - set(table.strings("tool")))
        if unused:
            raise InputError(f"--tool {unused[0]}: no row of {path} uses this tool id")
    elif by_id:
        raise InputError(
            f"--tool {next(iter(by_id))}: {path} has no 'tool' column of tool ids to match"
        )
    bad = np.flatnonzero(sph[:, 0] <= 0)
    if bad.size:
        raise InputError(f"{path}, data row {bad[0] + 1}: column 'range' must be > 0")
    check_temperatures(
        temps, lambda i: f"{path}, line {table.lines[i // 3]}: column 'T_{'XYZ'[i % 3]}'"
    )
    meas = TrackerMeasurements(readings, tool_rows, sph, temps, {"source": str(path)})
    if machine is not None:
        check_plausible(machine, meas, lambda i: f"{path}, line {table.lines[i]}")
    return meas


#: Largest RMS (mm) of the tracker points about the commanded tool points after the best
#: rigid fit, plus this share of the mesh's extent: a machine's errors and the scale's
#: expansion stay far below (tens of µm per metre); angles read in the wrong unit or a
#: range in metres leave hundreds of mm.
CONGRUENCE_MM = 1.0
CONGRUENCE_SHARE = 1e-3


def check_plausible(machine: Machine, meas: TrackerMeasurements, where) -> None:
    """Refuse readings that cannot be what the file says they are.

    - X, Y, Z of every row inside the travel of ``machine``;
    - every reading within the tracker's limits (:class:`TrackerLimits`, the paper's);
    - the tracker points (range, azimuth, elevation in mm and degrees) congruent with the
      nominal tool points the rows command: after the best rigid fit (Kabsch) the RMS of
      the differences must stay below :data:`CONGRUENCE_MM` plus :data:`CONGRUENCE_SHARE`
      of the mesh's extent.

    ``where(i)`` names row i (file and line).

    Raises
    ------
    InputError
        The first row outside the travel, or the row farthest from the fit.
    """
    for k, a in enumerate("XYZ"):
        travel = machine.axes[a].travel if a in machine.axis_names else None
        if travel is not None:
            check_within(
                meas.readings[:, k],
                *travel,
                lambda i, a=a: f"{where(i)}: column '{a}'",
                what=f"travel of {a} of {machine.name}",
            )
    TrackerLimits().check(meas.spherical, where=where)
    q = np.zeros((len(meas), machine.n_axes))
    for k, a in enumerate("XYZ"):
        if a in machine.axis_names:
            q[:, machine.axis_names.index(a)] = meas.readings[:, k]
    nominal = machine.forward(q, tool=meas.tools)
    seen = cartesian(meas.spherical)
    a0, b0 = nominal - nominal.mean(axis=0), seen - seen.mean(axis=0)
    u, _, vt = np.linalg.svd(b0.T @ a0)
    d = np.sign(np.linalg.det(u @ vt))
    rot = u @ np.diag([1.0, 1.0, d]) @ vt  # seen ≈ rot · nominal
    miss = np.linalg.norm(b0 - a0 @ rot.T, axis=1)
    rms = float(np.sqrt(np.mean(miss**2)))
    extent = float(np.ptp(nominal, axis=0).max())
    if rms > CONGRUENCE_MM + CONGRUENCE_SHARE * extent:
        i = int(np.argmax(miss))
        raise InputError(
            f"{where(i)}: the tracker readings do not match the commanded positions (RMS "
            f"{rms:.3g} mm after the best rigid fit, this row {miss[i]:.3g} mm); range in mm, "
            "azimuth and elevation in degrees?"
        )


def geometric_draws(
    rng: np.random.Generator, theta: np.ndarray, conditions: MachineConditions, size: int
) -> np.ndarray:
    """Random parts of the error parameters (eqs 18–20), shape (size, n_params)."""
    u = conditions.geometric_random * np.abs(theta)
    if conditions.geometric_distribution == "beta":
        z = Beta(-np.sqrt(5.0), np.sqrt(5.0), 2.0, 2.0).sample(rng, (size, theta.size))
    else:
        z = rng.standard_normal((size, theta.size))
    return z * u


def effective_readings(
    rng: np.random.Generator,
    machine: Machine,
    readings: np.ndarray,
    conditions: MachineConditions,
    size: int,
):
    """Where the axes really are and what the sensors read, for ``size`` tests.

    Returns ``(q_eff (size, n, 3), recorded temperatures (size, n, 3))`` (module notes of
    :mod:`mtmetrology.tracker.setup`).
    """
    senses = senses_from_sequence(readings)
    t_true = conditions.temperatures(machine, readings)  # (n, 3)
    sensor_err = conditions.u_sensor * rng.standard_normal((size, 3, 2))
    lo = np.array([machine.axes[a].travel[0] for a in "XYZ"])
    hi = np.array([machine.axes[a].travel[1] for a in "XYZ"])
    frac = (readings - lo) / (hi - lo)
    t_rec = (
        t_true
        + sensor_err[:, None, :, 0]
        + (sensor_err[:, None, :, 1] - sensor_err[:, None, :, 0]) * frac
    )
    cte = conditions.cte + conditions.u_cte * rng.standard_normal((size, 3))
    noise = conditions.repeatability * rng.standard_normal((size, *readings.shape))
    q = readings + senses * conditions.reversal / 2.0 + noise
    return q * (1.0 + cte[:, None, :] * (t_true - 20.0)), t_rec


def simulate(
    machine: Machine,
    truth: np.ndarray,
    pose: TrackerPose,
    mesh: np.ndarray,
    tools: np.ndarray,
    *,
    noise: TrackerNoise | None = None,
    conditions: MachineConditions | None = None,
    limits: TrackerLimits | None = None,
    seed: SeedLike = None,
) -> TrackerMeasurements:
    """Simulate one tracker verification (module notes).

    Parameters
    ----------
    machine : Machine
        The machine and its active error model.
    truth : (n_params,) ndarray
        True error parameters, internal units, in ``machine.parameter_names`` order.
    pose : TrackerPose
    mesh : (n, 3) ndarray
        Commanded mesh points, mm (:func:`~mtmetrology.tracker.setup.parse_mesh`).
    tools : (n_t, 3) ndarray
        Tool offsets, mm: every mesh point is measured with each.
    noise, conditions, limits
        Tracker noise (paper defaults), machine conditions (20 °C, no reversal), limits.
    seed : int, optional

    Returns
    -------
    TrackerMeasurements

    Raises
    ------
    InputError
        A tracker inside the workspace, a point beyond the tracker's limits, a NaN.
    """
    noise = noise or TrackerNoise()
    conditions = conditions or MachineConditions()
    limits = limits or TrackerLimits()
    theta = np.asarray(truth, dtype=float)
    if theta.shape != (machine.n_params,) or not np.all(np.isfinite(theta)):
        raise InputError(f"truth: need {machine.n_params} finite parameters of {machine.name}")
    readings, tool_rows = measurement_points(mesh, tools)
    nominal = machine.forward(readings, tool=tool_rows)
    check_pose(pose, machine, nominal, limits)
    rng = as_generator(seed)
    q_eff, t_rec = effective_readings(rng, machine, readings, conditions, 1)
    theta_k = theta + geometric_draws(rng, theta, conditions, 1)[0]
    true_points = machine.forward(q_eff[0], theta_k, tool=tool_rows)
    exact = spherical(pose.to_tracker(true_points))
    read = noise.sample_readings(rng, exact[None])[0]
    smr = noise.sample_smr(rng, (len(readings),))
    if noise.u_smr > 0:
        read = spherical(cartesian(read) + smr)
    provenance = {
        "machine": machine.name,
        "model": machine.model_name,
        "pose": pose.to_dict(),
        "noise": noise.to_dict(),
        "conditions": conditions.to_dict(),
        "seed": seed if isinstance(seed, int) else None,
    }
    return TrackerMeasurements(readings, tool_rows, read, t_rec[0], provenance)
