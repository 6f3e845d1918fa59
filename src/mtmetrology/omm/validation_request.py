"""The validation campaigns of a task uncertainty from their files (``mtm task validate``,
``mtm task validate-pooling``).

:func:`validate_gauge_from_files` reads the two sides' readings, the calibration, the
long-term variation, the repeatability model and cov(e), carries the calibrated length to
the measurement temperature (eqs. 6-17 to 6-19) and runs
:func:`~mtmetrology.omm.validation.validate_gauge`: the command line and a notebook get the
same :class:`~mtmetrology.omm.validation.GaugeValidation`, with the thermal reference and
the source files in its document. :func:`pooling_from_files` does the same for the
pooling test (§6.5): the sphere point sets, the diameter carried to the measurement
temperature and the sphericity, into :func:`~mtmetrology.omm.pooling.pooling_experiment`.

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, §6.4 (eqs. 6-16 to 6-19), §6.5.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.fitting.features import SphereDiameter, Sphericity
from mtmetrology.io import read_csv_table
from mtmetrology.io.plausibility import (
    check_positive,
    check_scale,
    check_uncertainty,
    distinct_files,
)
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.kinematics.readings_table import readings_from_table
from mtmetrology.omm.pooling import PoolingResult, pooling_experiment
from mtmetrology.omm.reference import thermal_reference_value
from mtmetrology.omm.repeatability_file import load_repeatability_model
from mtmetrology.omm.repeatability_model import RepeatabilityModel
from mtmetrology.omm.task import reading_covariance
from mtmetrology.omm.task_request import load_calibration, ordered_covariance
from mtmetrology.omm.unexplained import load_unexplained_covariance
from mtmetrology.omm.validation import GaugeValidation, validate_gauge

__all__ = ["pooling_from_files", "read_side", "validate_gauge_from_files"]


def read_side(
    path: str | Path, machine: Machine, repeatability: RepeatabilityModel | None = None
) -> tuple[np.ndarray, np.ndarray | None]:
    """The readings of one face (CSV ``point``, one column per axis, ``i,j,k`` with a
    repeatability model) and, with ``repeatability``, their covariances v (mm², rad²)."""
    table = read_csv_table(path, required=("point",))
    readings = readings_from_table(machine, table)
    if repeatability is None:
        return readings, None
    return readings, reading_covariance(machine, repeatability, readings, table.vectors("ijk"))


def validate_gauge_from_files(
    side_a: str | Path,
    side_b: str | Path,
    machine: str | Path | Machine,
    params: str | Path,
    calibrated_length: float,
    calibration_uncertainty: float,
    *,
    expansion_coefficient: float = 0.0,
    expansion_coefficient_uncertainty: float = 0.0,
    temperature_difference: float = 0.0,
    temperature_difference_uncertainty: float = 0.0,
    long_term: str | Path | None = None,
    recalibrated: bool = False,
    repeatability: str | Path | None = None,
    unexplained: str | Path | None = None,
    tip_diameter: float | None = None,
    p: float = 0.95,
) -> GaugeValidation:
    """Coverage of the compensated gauge lengths of every side-A × side-B bipoint.

    The reference is the calibrated length carried to the measurement temperature,
    y_cal = y_cal,20 (1 + αΔT) with u_cal from eq. 6-19
    (:func:`~mtmetrology.omm.reference.thermal_reference_value`); each bipoint's interval
    y ± U is the full-covariance GUF of the compensated length and eq. 6-16 the
    probability that it holds y_cal (:func:`~mtmetrology.omm.validation.validate_gauge`).

    Parameters
    ----------
    side_a, side_b : path
        CSV of the points probed on each face: ``point``, one column per axis (mm,
        degrees), ``i,j,k`` with ``repeatability``.
    machine : Machine, preset name or machine YAML
    params : path
        The calibration that compensates (parameter set with its covariance U_θ).
    calibrated_length, calibration_uncertainty : float, mm
        y_cal,20 and its standard uncertainty at 20 °C.
    expansion_coefficient, expansion_coefficient_uncertainty : float, 1/°C
        α of the gauge and u(α).
    temperature_difference, temperature_difference_uncertainty : float, °C
        ΔT = gauge temperature − 20 °C during probing, and u(ΔT).
    long_term : path, optional
        Parameter set whose covariance is the variation Σ_lt of the parameters between
        calibrations; one of ``long_term`` and ``recalibrated`` is required.
    recalibrated : bool
        The machine is recalibrated for the campaign: no long-term term.
    repeatability, unexplained : path, optional
        ``repeatability-model`` JSON (the sides then need ``i,j,k``); the
        unexplained-volumetric-error document (µm²), which also gives the ablation.
    tip_diameter : float, mm, optional
        Effective tip diameter subtracted from each centre distance (default: the
        machine's).
    p : float
        Coverage probability of each interval.

    Returns
    -------
    GaugeValidation
        With ``thermal_reference`` (the eqs. 6-17 to 6-19 propagation) and ``source``
        naming the files.

    Raises
    ------
    InputError
        Neither or both of ``long_term`` and ``recalibrated``, a calibration or long-term
        set without covariance, a bad file, a reference length not > 0.

    References
    ----------
    Sepahi Boroujeni (2021), §6.4, eqs. 6-16 to 6-19.
    """
    if recalibrated == (long_term is not None):
        raise InputError("give one of --long-term FILE and --recalibrated")
    check_positive(calibrated_length, "--reference-mm")
    check_uncertainty(calibration_uncertainty, "--reference-u-um")
    base, pset, model = load_calibration(machine, params)
    sigma_lt = None
    if long_term is not None:
        lt = ParameterSet.load(long_term, base)
        if lt.covariance is None or set(lt.names) != set(pset.names):
            raise InputError(f"{long_term}: needs a covariance over the parameters of {params}")
        sigma_lt = ordered_covariance(lt, model)
    rep = load_repeatability_model(repeatability) if repeatability is not None else None
    a, va = read_side(side_a, model, rep)
    b, vb = read_side(side_b, model, rep)
    # a reference in m or µm is 10³ off the distance the faces' points show
    faces = [model.forward(r).mean(axis=0) for r in (a, b)]
    check_scale(
        calibrated_length,
        float(np.linalg.norm(faces[1] - faces[0])),
        "--reference-mm",
        against="the distance between the mean points of the two faces",
    )
    cov_e = load_unexplained_covariance(unexplained) if unexplained is not None else None
    reference = thermal_reference_value(
        calibrated_length,
        calibration_uncertainty,
        expansion_coefficient=expansion_coefficient,
        expansion_coefficient_uncertainty=expansion_coefficient_uncertainty,
        temperature_difference=temperature_difference,
        temperature_difference_uncertainty=temperature_difference_uncertainty,
        name="gauge_length",
    )
    result = validate_gauge(
        model,
        a,
        b,
        pset.vector_for(model),
        ordered_covariance(pset, model),
        reference.value,
        reference.standard_uncertainty,
        tip_diameter=2.0 * model.tip_radius if tip_diameter is None else tip_diameter,
        long_term_covariance=sigma_lt,
        recalibrated=recalibrated,
        reading_covariance_a=va,
        reading_covariance_b=vb,
        unexplained_covariance=cov_e,
        p=p,
    )
    source = {"side_a": str(side_a), "side_b": str(side_b), "params": str(params)}
    return replace(result, thermal_reference=reference.to_dict(), source=source)


def pooling_from_files(
    sets: list[str | Path],
    machine: str | Path | Machine,
    params: str | Path,
    calibrated_diameter: float,
    calibration_uncertainty: float,
    *,
    sphericity: float | None = None,
    sphericity_uncertainty: float = 0.0,
    expansion_coefficient: float = 0.0,
    expansion_coefficient_uncertainty: float = 0.0,
    temperature_difference: float = 0.0,
    temperature_difference_uncertainty: float = 0.0,
    repeatability: str | Path | None = None,
    unexplained: str | Path | None = None,
    tip_diameter: float | None = None,
    k_values: list[int] | None = None,
    draws: int = 200,
    points_per_draw: int = 25,
    p: float = 0.95,
    seed: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> PoolingResult:
    """Coverage of sphere diameter (and sphericity) intervals on draws pooled from k sets.

    The diameter's reference is the calibrated value carried to the measurement
    temperature, d = d_20 (1 + αΔT) with u from eq. 6-19; the sphericity's is taken as
    calibrated (thermal effects on form neglected, §6.4). Each draw of ``points_per_draw``
    points from k of the sets is compensated and given its full-covariance GUF interval;
    the coverage is the mean of eq. 6-16 over the draws
    (:func:`~mtmetrology.omm.pooling.pooling_experiment`).

    Parameters
    ----------
    sets : list of path
        CSV of each sphere point set (one pose each): ``point``, one column per axis (mm,
        degrees), ``i,j,k`` with ``repeatability``.
    machine : Machine, preset name or machine YAML
    params : path
        The calibration that compensates (parameter set with its covariance U_θ).
    calibrated_diameter, calibration_uncertainty : float, mm
        d_20 and its standard uncertainty at 20 °C.
    sphericity, sphericity_uncertainty : float, mm, optional
        Calibrated sphericity and its standard uncertainty: the sphericity is then a
        second output.
    expansion_coefficient, expansion_coefficient_uncertainty : float, 1/°C
    temperature_difference, temperature_difference_uncertainty : float, °C
        ΔT = sphere temperature − 20 °C, and u(ΔT).
    repeatability, unexplained : path, optional
        ``repeatability-model`` JSON; the unexplained-volumetric-error document (µm²).
    tip_diameter : float, mm, optional
        Effective tip diameter (default: the machine's).
    k_values, draws, points_per_draw, p, seed, progress
        As :func:`~mtmetrology.omm.pooling.pooling_experiment`.

    Returns
    -------
    PoolingResult
        With ``source`` naming the files; a draw whose sphere fit failed is excluded and
        named by its files in ``failed``.

    Raises
    ------
    InputError
        A calibration without covariance, a bad file, a diameter not > 0, a set given
        twice, or what
        :func:`~mtmetrology.omm.pooling.pooling_experiment` refuses (k outside 1 … n).

    References
    ----------
    Sepahi Boroujeni (2021), §6.4 (eqs. 6-16 to 6-19), §6.5.
    """
    check_positive(calibrated_diameter, "--diameter-mm")
    check_uncertainty(calibration_uncertainty, "--diameter-u-um")
    distinct_files(sets, "sphere point sets")
    _, pset, model = load_calibration(machine, params)
    rep = load_repeatability_model(repeatability) if repeatability is not None else None
    read = [read_side(path, model, rep) for path in sets]
    diameter = thermal_reference_value(
        calibrated_diameter,
        calibration_uncertainty,
        expansion_coefficient=expansion_coefficient,
        expansion_coefficient_uncertainty=expansion_coefficient_uncertainty,
        temperature_difference=temperature_difference,
        temperature_difference_uncertainty=temperature_difference_uncertainty,
        name="sphere_diameter",
    )
    d_tip = 2.0 * model.tip_radius if tip_diameter is None else tip_diameter
    features, references = [SphereDiameter(d_tip)], [diameter]
    if sphericity is not None:
        features.append(Sphericity())
        references.append((sphericity, sphericity_uncertainty))
    result = pooling_experiment(
        model,
        [r for r, _ in read],
        pset.vector_for(model),
        ordered_covariance(pset, model),
        features,
        references,
        reading_covariance=None if rep is None else [v for _, v in read],
        unexplained_covariance=(
            load_unexplained_covariance(unexplained) if unexplained is not None else None
        ),
        k_values=k_values,
        draws=draws,
        points_per_draw=points_per_draw,
        p=p,
        seed=seed,
        set_names=[Path(path).name for path in sets],
        progress=progress,
    )
    return replace(result, source={"sets": [str(s) for s in sets], "params": str(params)})
