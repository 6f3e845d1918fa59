"""What the ``mtm rtest`` commands do, one library call each, from files and options.

The readings CSV holds one row per indexation: the machine's axis readings (linear in mm,
rotary in degrees, e.g. ``X,Y,Z,B,C``; a missing spindle ``S`` is 0) and one column per
sensor, ``s1_um, s2_um, s3_um[, s4_um]`` (µm, the sensor's reading).  The sensors file
(YAML, optional; three orthogonal sensors along the tool frame's +X, +Y, +Z with gain 1
otherwise)::

    kind: rtest-sensors
    version: 1
    directions: [[1, 0, -1], [0, 1, -1], [-1, 0, -1]]   # tool frame, normalised on reading
    gains: [1.0, 1.0, 1.0]
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.formatting import format_uncertainty, format_value
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameters import parse_parameter
from mtmetrology.kinematics.topology import LINEAR_AXES
from mtmetrology.rtest.calibrate import RTestCalibration, calibrate, simulate
from mtmetrology.rtest.model import Sensors, indexations
from mtmetrology.uncertainty.coverage import DEFAULT
from mtmetrology.units import from_internal, to_internal

__all__ = [
    "calibrate_file",
    "calibration_summary",
    "load_sensors",
    "programme_grid",
    "read_rtest",
    "simulate_file",
    "values_from_pairs",
]


def load_sensors(path: str | Path | None) -> Sensors:
    """The sensors of a sensors file, or three orthogonal ones with gain 1."""
    if path is None:
        return Sensors()
    from mtmetrology.io.documents import load_document

    doc = load_document(path, "R-test sensors file")
    if not isinstance(doc, dict) or doc.get("kind") != "rtest-sensors":
        raise InputError(f"{path}: kind must be rtest-sensors")
    if "directions" not in doc:
        raise InputError(f"{path}: missing directions")
    try:
        directions = np.asarray(doc["directions"], dtype=float)
        gains = np.asarray(doc.get("gains", np.ones(len(directions))), dtype=float)
    except (TypeError, ValueError) as err:
        raise InputError(f"{path}: directions and gains must be numbers ({err})") from None
    try:
        return Sensors(directions, gains)
    except InputError as err:
        raise InputError(f"{path}: {err}") from None


def programme_grid(machine: Machine, specs: Sequence[str], sphere) -> np.ndarray:
    """Readings of the grid of rotary indexations ``AXIS=start:stop:step`` (degrees, stop
    included) that put the nest at the sphere's nominal centre.

    Raises
    ------
    InputError
        A spec not of that form, an axis the machine lacks, a zero step.
    """
    rotary = [a for a in machine.axis_names if a not in LINEAR_AXES and a != "S"]
    values = {a: np.zeros(1) for a in [*rotary, "S"] if a in machine.axis_names}
    for spec in specs:
        axis, _, text = spec.partition("=")
        axis = axis.strip().upper()
        parts = text.split(":")
        try:
            start, stop, step = (float(v) for v in parts)
        except ValueError:
            raise InputError(f"--index {spec!r}: expected AXIS=start:stop:step (degrees)") from None
        if axis not in rotary:
            raise InputError(f"--index {spec!r}: {axis} is not a rotary axis of {machine.name}")
        if step <= 0 or stop < start:
            raise InputError(f"--index {spec!r}: the step must be positive and stop ≥ start")
        deg = np.arange(start, stop + 0.5 * step, step)
        values[axis] = to_internal(deg, "deg")
    grid = np.meshgrid(*values.values(), indexing="ij")
    return indexations(machine, sphere, np.column_stack([g.ravel() for g in grid]))


def values_from_pairs(machine: Machine, pairs: Sequence[str], option: str) -> dict[str, float]:
    """``NAME=VALUE`` ISO 230-1 errors in the machine's customary units → internal."""
    out = {}
    for pair in pairs:
        name, sep, text = pair.partition("=")
        try:
            value = float(text)
            param = parse_parameter(name)
        except ValueError:
            raise InputError(f"{option} {pair!r}: expected NAME=VALUE (E_X0C=10)") from None
        if not (sep and np.isfinite(value)):
            raise InputError(f"{option} {pair!r}: expected NAME=VALUE with a finite number")
        out[param.name] = float(to_internal(value, machine.unit_of(param)))
    return out


def _columns(machine: Machine, sensors: int) -> list[str]:
    return [*machine.axis_names, *(f"s{j + 1}_um" for j in range(sensors))]


def simulate_file(
    machine: Machine,
    specs: Sequence[str],
    sphere,
    sensors: Sensors,
    truth: dict[str, float],
    output: str | Path,
    *,
    true_sphere=None,
    noise: float = 0.0,
    seed=None,
) -> int:
    """Write the readings CSV of a virtual R-test; returns the number of indexations."""
    from mtmetrology.io.tables import write_csv_table

    q = programme_grid(machine, specs, sphere)
    s = simulate(
        machine,
        q,
        sensors,
        truth,
        sphere=sphere if true_sphere is None else true_sphere,
        sigma=noise,
        seed=seed,
    )
    customary = machine.readings_to_customary(q)
    um = from_internal(s, "µm")
    rows = [[f"{v:.9f}" for v in customary[k]] + [f"{v:.6f}" for v in um[k]] for k in range(len(q))]
    write_csv_table(output, _columns(machine, sensors.count), rows)
    return len(q)


def read_rtest(path: str | Path, machine: Machine, sensors: Sensors):
    """Axis readings (n, n_axes; mm, rad) and sensor readings (n, k; mm) of a readings CSV.

    Raises
    ------
    InputError
        A missing column (axis or sensor), a non-numeric cell, named by file and line.
    """
    from mtmetrology.io.tables import read_csv_table
    from mtmetrology.kinematics.readings_table import readings_from_table

    sensor_cols = [f"s{j + 1}_um" for j in range(sensors.count)]
    table = read_csv_table(path, required=sensor_cols)
    q = readings_from_table(machine, table)
    sensed = to_internal(table.vectors(sensor_cols), "µm")
    return q, sensed


def calibrate_file(
    machine: Machine,
    path: str | Path,
    sensors: Sensors,
    *,
    sphere,
    parameters: Sequence[str] | None = None,
    sigma: float | None = None,
    adequacy: str = "scale",
) -> RTestCalibration:
    """The R-test calibration of a readings CSV (:func:`~mtmetrology.rtest.calibrate`)."""
    q, sensed = read_rtest(path, machine, sensors)
    return calibrate(
        machine,
        q,
        sensed,
        sensors,
        sphere=sphere,
        parameters=parameters,
        sigma=sigma,
        adequacy=adequacy,
    )


def calibration_summary(result: RTestCalibration) -> str:
    """Console lines: the identified errors with u (2 significant digits) and U (the
    coverage policy's k), and what the programme could not separate."""
    lines = [
        f"R-test of {result.machine.name}: {result.problem.readings.shape[0]} indexations, "
        f"{result.problem.sensors.count} sensors",
        f"  {result.identification.message}",
        f"  datum: {result.datum.message}",
        f"  covariance: {result.covariance_source}",
        f"  {'parameter':<16} {'value':>12} {'u':>9} {f'U ({DEFAULT.label})':>10}  unit",
    ]
    for row in result.parameter_rows():
        if row["nuisance"]:
            continue
        lines.append(
            f"  {row['name']:<16} {format_value(row['value'], row['u']):>12} "
            f"{format_uncertainty(row['u']):>9} {format_uncertainty(row['U']):>10}  {row['unit']}"
        )
    return "\n".join(lines)
