"""One on-machine task-uncertainty request from its files (``mtm task uncertainty``).

:func:`task_uncertainty_from_files` reads the probed readings, the calibration, the
long-term variation, the repeatability model and cov(e), builds the feature, runs
:func:`~mtmetrology.omm.task.task_uncertainty` and attaches the ISO 14253-1 decision: the
command line and a notebook get the same :class:`~mtmetrology.omm.task.TaskResult`.
Measurement model: :mod:`mtmetrology.omm.task` (Sepahi Boroujeni (2021), ch. 6–7).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.fitting.composite import CombinedFeature, PointCoordinates
from mtmetrology.fitting.features import (
    BallCentre,
    CircleCentre,
    CircleDiameter,
    CylinderDiameter,
    Cylindricity,
    Flatness,
    GaugeLength,
    Roundness,
    SphereDiameter,
    Sphericity,
)
from mtmetrology.fitting.zone_features import (
    MinimumZoneCylindricity,
    MinimumZoneFlatness,
    MinimumZoneRoundness,
    MinimumZoneSphericity,
)
from mtmetrology.io import read_csv_table
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.kinematics.readings_table import readings_from_table, senses_from_table
from mtmetrology.omm.repeatability_file import load_repeatability_model
from mtmetrology.omm.task import TaskResult, reading_covariance, task_uncertainty
from mtmetrology.omm.unexplained import load_unexplained_covariance
from mtmetrology.uncertainty.conformity import Tolerance, decide
from mtmetrology.uncertainty.coverage import DEFAULT_P

__all__ = [
    "DEFAULT_SIDE",
    "FEATURES",
    "FORM_FEATURES",
    "load_calibration",
    "ordered_covariance",
    "task_feature",
    "task_points",
    "task_uncertainty_from_files",
]

#: The features of a task, by name.
FEATURES = (
    "length",
    "sphere",
    "circle",
    "plane",
    "cylinder",
    "sphere-centre",
    "circle-centre",
    "points",
)
#: The features with a form error, which ``form="minimum-zone"`` may evaluate.
FORM_FEATURES = ("sphere", "circle", "plane", "cylinder")
#: Default side: a ball is probed from outside, a circle or a cylinder is a bore.
DEFAULT_SIDE = {"sphere": "outer", "circle": "inner", "cylinder": "inner"}


def task_feature(name: str, form: str, side: str | None, d_tip: float, n_points: int):
    """The feature function g(q) of a task.

    The size (tip-compensated, least squares) and the form (least-squares peak-to-valley
    or minimum zone, ISO 1101) of the element, its centre, or the compensated coordinates
    themselves (Sepahi Boroujeni (2021), Table 7-1).

    Parameters
    ----------
    name : str
        One of :data:`FEATURES`.
    form : {"least-squares", "minimum-zone"}
        How the form error is evaluated.
    side : {"inner", "outer"} or None
        Probed from inside (bore) or outside; None: :data:`DEFAULT_SIDE`.
    d_tip : float
        Effective tip diameter, mm.
    n_points : int
        Number of points (the ``points`` feature returns 3 n coordinates).

    Returns
    -------
    Feature
        One feature, or a :class:`~mtmetrology.fitting.composite.CombinedFeature`.
    """
    inner = (side or DEFAULT_SIDE.get(name, "outer")) == "inner"
    zone = form == "minimum-zone"
    parts = {
        "length": lambda: (GaugeLength(tip_diameter=d_tip),),
        "sphere": lambda: (
            SphereDiameter(d_tip, inner=inner),
            MinimumZoneSphericity() if zone else Sphericity(),
        ),
        "circle": lambda: (
            CircleDiameter(inner=inner, tip_diameter=d_tip),
            MinimumZoneRoundness() if zone else Roundness(),
        ),
        "plane": lambda: (MinimumZoneFlatness() if zone else Flatness(),),
        "cylinder": lambda: (
            CylinderDiameter(inner=inner, tip_diameter=d_tip),
            MinimumZoneCylindricity() if zone else Cylindricity(),
        ),
        "sphere-centre": lambda: (BallCentre(name="sphere_centre"),),
        "circle-centre": lambda: (CircleCentre(),),
        "points": lambda: (PointCoordinates(n_points),),
    }[name]()
    return parts[0] if len(parts) == 1 else CombinedFeature(parts)


def load_calibration(
    machine: str | Path | Machine, params: str | Path
) -> tuple[Machine, ParameterSet, Machine]:
    """The machine (preset name, machine YAML or object), the calibration ``params`` that
    compensates it, and the machine restricted to the calibration's parameters.

    Raises
    ------
    InputError
        A calibration without covariance (a task uncertainty needs U_θ), a bad file.
    """
    base = machine if isinstance(machine, Machine) else Machine.load(machine)
    pset = ParameterSet.load(params, base)
    model = pset.machine_for(base)
    if pset.covariance is None:
        raise InputError(f"{params}: no covariance; the task uncertainty needs one")
    return base, pset, model


def ordered_covariance(pset: ParameterSet, machine: Machine) -> np.ndarray:
    """The set's covariance in ``machine.parameter_names`` order (mm², rad², mm·rad)."""
    order = [pset.names.index(n) for n in machine.parameter_names]
    return pset.covariance[np.ix_(order, order)]


def task_points(path: str | Path, machine: Machine, feature: str, need_approach: bool):
    """Readings (mm, rad), approach directions and senses of a task's points file.

    ``point`` and one column per axis; ``i,j,k`` when ``need_approach``; for a length two
    rows, ordered by an optional ``end`` column (1, 2).

    Returns
    -------
    readings : (n, n_axes) ndarray
    approach : (n, 3) ndarray or None
    senses : (n, n_axes) ndarray or None
    """
    table = read_csv_table(path, required=("point",))
    readings = readings_from_table(machine, table)
    order = np.arange(len(table))
    if feature == "length":
        if len(table) != 2:
            raise InputError(
                f"{path}: a length needs exactly 2 points (one pair), got {len(table)}"
            )
        if table.has("end"):
            ends = table.floats("end")
            if sorted(ends.tolist()) != [1.0, 2.0]:
                raise InputError(f"{path}: column 'end' must hold 1 and 2")
            order = np.argsort(ends)
    approach = table.vectors("ijk")[order] if need_approach else None
    senses = senses_from_table(machine, table)
    return readings[order], approach, None if senses is None else senses[order]


def _tolerance_index(feature, name: str | None, tol: Tolerance | None) -> int:
    """Index of the toleranced output: the named one, else the feature's first."""
    names = list(feature.output_names)
    if name is None:
        return 0
    if tol is None:
        raise InputError("--tolerance-output needs --tolerance")
    if name not in names:
        raise InputError(f"--tolerance-output: {name!r} is not an output ({', '.join(names)})")
    return names.index(name)


def task_uncertainty_from_files(
    points: str | Path,
    machine: str | Path | Machine,
    params: str | Path,
    feature: str,
    *,
    long_term: str | Path | ParameterSet | None = None,
    long_term_source: str | None = None,
    recalibrated: bool = False,
    repeatability: str | Path | None = None,
    unexplained: str | Path | None = None,
    form: str = "least-squares",
    side: str | None = None,
    tip_diameter: float | None = None,
    method: str = "guf",
    simulator: str = "linear",
    draws: int = 10_000,
    trials: int | None = None,
    digits: int = 2,
    seed: int | None = None,
    tolerance: str | Tolerance | None = None,
    tolerance_output: str | None = None,
    guard_band_factor: float = 1.0,
    p: float = DEFAULT_P,
) -> TaskResult:
    """Value, u, U, budget and ISO 14253-1 decision of a feature probed on the machine.

    The readings are compensated with the calibration's estimate Δ and the feature
    y = g(f(Γ, Δ) + E) is evaluated with its uncertainty (full-covariance GUF and/or
    adaptive Monte Carlo, :func:`~mtmetrology.omm.task.task_uncertainty`).

    Parameters
    ----------
    points : path
        CSV: ``point``, one column per axis (mm, degrees), ``i,j,k`` with
        ``repeatability``, ``end`` (1, 2) for a length, optional ``sense_<axis>``.
    machine : Machine, preset name or machine YAML
    params : path
        The calibration (parameter set with its covariance U_θ).
    feature : str
        One of :data:`FEATURES`.
    long_term : path or ParameterSet, optional
        Whose covariance is the variation of the parameters between calibrations; one of
        ``long_term`` and ``recalibrated`` is required.
    long_term_source : str, optional
        What ``document["source"]["long_term"]`` records for a ParameterSet (e.g.
        ``history:MACHINE``); a path records itself.
    recalibrated : bool
        The machine is recalibrated for the task: no long-term term.
    repeatability, unexplained : path, optional
        ``repeatability-model`` JSON; the unexplained-volumetric-error document (µm²).
    form, side, tip_diameter
        As :func:`task_feature`; tip diameter in mm, default the machine's.
    method, simulator, draws, trials, digits, seed, p
        As :func:`~mtmetrology.omm.task.task_uncertainty`.
    tolerance : Tolerance or "NOMINAL,LOWER,UPPER" (mm), optional
    tolerance_output : str, optional
        The output the tolerance applies to (default: the feature's first).
    guard_band_factor : float
        Guard bands h·U (ISO 14253-1:2017, default h = 1).

    Returns
    -------
    TaskResult
        With ``decision`` when a tolerance is given and ``source`` naming the files.

    Raises
    ------
    InputError
        A contradictory request, a missing covariance, too few points, a bad file.

    References
    ----------
    Sepahi Boroujeni (2021), ch. 6–7; ISO 14253-1:2017.
    """
    tol = Tolerance.parse(tolerance) if isinstance(tolerance, str) else tolerance
    if feature not in FEATURES:
        raise InputError(f"feature {feature!r}: not one of {', '.join(FEATURES)}")
    if recalibrated and long_term is not None:
        raise InputError(
            "--long-term and --recalibrated: a machine recalibrated for the task has no "
            "long-term term; give one of them"
        )
    if not recalibrated and long_term is None:
        raise InputError(
            "state the long-term variation of the parameters since the calibration: "
            "--long-term FILE (mtm samba long-term), or --recalibrated"
        )
    if side is not None and feature not in DEFAULT_SIDE:
        raise InputError(f"--side applies to a sphere, circle or cylinder, not to a {feature}")
    if form == "minimum-zone" and feature not in FORM_FEATURES:
        raise InputError(f"--form minimum-zone applies to a form error, not to a {feature}")
    base, pset, model = load_calibration(machine, params)
    sigma_lt = None
    if long_term is not None:
        lt = (
            long_term if isinstance(long_term, ParameterSet) else ParameterSet.load(long_term, base)
        )
        label = long_term_source if isinstance(long_term, ParameterSet) else str(long_term)
        if lt.covariance is None:
            raise InputError(f"{label}: no covariance; --long-term needs one")
        if set(lt.names) != set(pset.names):
            raise InputError(f"{label}: parameter names differ from those of {params}")
        sigma_lt = ordered_covariance(lt, model)
    readings, approach, senses = task_points(points, model, feature, repeatability is not None)
    d_tip = 2.0 * model.tip_radius if tip_diameter is None else tip_diameter
    feat = task_feature(feature, form, side, d_tip, len(readings))
    if len(readings) < feat.min_points:
        raise InputError(
            f"{points}: a {feature} needs at least {feat.min_points} points "
            f"({form}), got {len(readings)}"
        )
    v = None
    if repeatability is not None:
        v = reading_covariance(model, load_repeatability_model(repeatability), readings, approach)
    cov_e = load_unexplained_covariance(unexplained) if unexplained is not None else None
    target = _tolerance_index(feat, tolerance_output, tol)
    result = task_uncertainty(
        model,
        readings,
        pset.vector_for(model),
        ordered_covariance(pset, model),
        feat,
        long_term_covariance=sigma_lt,
        recalibrated=recalibrated,
        reading_covariance=v,
        unexplained_covariance=cov_e,
        senses=senses,
        p=p,
        method=method,
        simulator=simulator,
        draws=draws,
        trials=trials,
        digits=digits,
        seed=seed,
    )
    decision = None
    if tol is not None:
        out = result.result.outputs[target]
        decision = decide(out.value, out.U, tol, guard_band_factor=guard_band_factor, unit="mm")
    source = {"points": str(points), "params": str(params)}
    if long_term is not None:
        source["long_term"] = label
    return replace(result, decision=decision, source=source, target=target)
