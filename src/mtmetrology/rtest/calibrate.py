"""R-test calibration: the rotary axes' location errors (and error motions) from sensor readings.

The programme's Jacobian at the nominal point decides by rank which candidates it can
identify (:func:`mtmetrology.identification.choose_datum`: the sphere centre and sensor
zeros first, then the candidates, location errors before error motions); the kept ones
are identified by the identification engine
(:func:`~mtmetrology.identification.levenberg_marquardt`) and reported with the same
identifiability report as SAMBA (rank, condition, observability indices) plus what was
dropped and what absorbs it.

Uncertainty: with a stated sensor σ, ``(JᵀJ)⁻¹`` of the weighted problem under the
engine's adequacy rule; without one, σ from the residuals, ``s²(JᵀJ)⁻¹`` with
``s² = ‖r‖²/(m − n)`` (JCGM 100:2008, H.3: independent sensor errors of one unknown
standard deviation).  U = k u with k = 2.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from mtmetrology.errors import ConvergenceError, InputError
from mtmetrology.identification import (
    Datum,
    IdentificationResult,
    choose_datum,
    levenberg_marquardt,
)
from mtmetrology.kinematics.machine import Machine
from mtmetrology.rng import SeedLike, as_generator
from mtmetrology.rtest.model import RTestProblem, Sensors, rotary_location_candidates
from mtmetrology.uncertainty.coverage import DEFAULT, DEFAULT_K
from mtmetrology.units import from_internal, to_internal

__all__ = ["KIND", "RTestCalibration", "calibrate", "simulate"]

KIND = "r-test"
COVERAGE_FACTOR = DEFAULT_K  # the coverage policy (mtmetrology.uncertainty.coverage)
XTOL = 1e-6


def simulate(
    machine: Machine,
    readings: np.ndarray,
    sensors: Sensors,
    truth: Mapping[str, float],
    *,
    sphere,
    zeros=None,
    sigma: float = 0.0,
    seed: SeedLike = None,
) -> np.ndarray:
    """Sensor readings (n, k) of a virtual machine, mm (model (1) of
    :mod:`mtmetrology.rtest.model`).

    Parameters
    ----------
    machine : Machine
    readings : (n, n_axes) ndarray
        Axis readings of the indexations.
    sensors : Sensors
    truth : mapping
        ISO 230-1 name → true value, internal units.
    sphere : (3,) array_like
        True sphere centre, workpiece frame, mm.
    zeros : (k,) array_like, optional
        Sensor zeros, mm (0 by default).
    sigma : float
        Standard deviation of the sensor noise, mm.
    seed : int or Generator, optional
    """
    m = machine.with_parameters(list(truth))
    problem = RTestProblem(
        m,
        readings,
        np.zeros((len(readings), sensors.count)),
        sensors,
        sigma=1.0,
        sphere=sphere,
    )
    x = problem.initial()
    x[: m.n_params] = list(truth.values())
    if zeros is not None:
        x[m.n_params + 3 :] = zeros
    s = problem.model(x).reshape(len(readings), sensors.count)
    if sigma > 0:
        s = s + as_generator(seed).normal(0.0, sigma, s.shape)
    return s


@dataclass(frozen=True, eq=False)
class RTestCalibration:
    """Result of :func:`calibrate`.

    Attributes
    ----------
    machine : Machine
        With the identified (kept) parameters active.
    problem : RTestProblem
    identification : IdentificationResult
    datum : Datum
        Candidates kept and dropped by rank.
    covariance_source : str
    """

    machine: Machine
    problem: RTestProblem = field(repr=False)
    identification: IdentificationResult = field(repr=False)
    datum: Datum
    covariance_source: str

    @property
    def names(self) -> tuple[str, ...]:
        return self.identification.names

    def value(self, name: str) -> float:
        """Identified value of an unknown, internal units."""
        return self.identification.value(name)

    def u(self, name: str) -> float:
        """Standard uncertainty of an unknown, internal units."""
        return self.identification.u(name)

    def _scales_units(self):
        m = self.machine
        n_nuis = len(self.problem.nuisance)
        scales = np.concatenate([m.parameter_scales, [to_internal(1.0, "µm")] * n_nuis])
        return scales, [*m.parameter_units, *["µm"] * n_nuis]

    def parameter_rows(self) -> list[dict]:
        """``[{name, value, unit, u, U, k, nuisance}]`` in display units."""
        scales, units = self._scales_units()
        est = self.identification.estimate
        u = self.identification.standard_uncertainty
        return [
            {
                "name": n,
                "value": float(est[i] / scales[i]),
                "unit": units[i],
                "u": float(u[i] / scales[i]),
                "U": COVERAGE_FACTOR * float(u[i] / scales[i]),
                "k": COVERAGE_FACTOR,
                "nuisance": n in self.problem.nuisance,
            }
            for i, n in enumerate(self.names)
        ]

    def to_dict(self, machine_name: str | None = None) -> dict:
        """The result document (``kind: r-test``, a calibration): ``parameters`` and
        ``covariance`` are the location errors as a parameter set (``mtm export``,
        ``mtm predict`` and ``mtm history add`` read them), ``estimates`` every unknown
        with U and k (the nuisance sphere position too)."""
        from mtmetrology.kinematics.conventions import describe_parameters

        ident = self.identification
        scales, _ = self._scales_units()
        cov = ident.covariance / np.outer(scales, scales)
        res = from_internal(ident.residuals * self.problem.sigma, "µm")
        k = self.problem.sensors.count
        return {
            "kind": KIND,
            "version": 1,
            "machine": machine_name or self.machine.name,
            "category": "calibration",
            **ident.parameter_set_keys(self.machine, {"source": "R-test"}),
            "estimates": self.parameter_rows(),
            "estimate_covariance": {"names": list(self.names), "matrix": cov.tolist()},
            "covariance_source": self.covariance_source,
            "coverage": DEFAULT.to_dict(),
            "conventions": [c.to_dict() for c in describe_parameters(self.machine)],
            "sensors": self.problem.sensors.to_dict(),
            "indexations": int(self.problem.readings.shape[0]),
            "datum": self.datum.to_dict(),
            "identifiability": ident.diagnostics.to_dict(),
            "identification": {
                "message": ident.message,
                "success": ident.success,
                "dof": ident.dof,
                "variance_factor": ident.variance_factor,
            },
            **({} if ident.adequacy is None else {"adequacy": ident.adequacy.to_dict()}),
            "residual_rms_um": {
                f"sensor {j + 1}": float(np.sqrt(np.mean(res.reshape(-1, k)[:, j] ** 2)))
                for j in range(k)
            },
        }


def calibrate(
    machine: Machine,
    readings: np.ndarray,
    sensed: np.ndarray,
    sensors: Sensors,
    *,
    sphere,
    parameters: Sequence[str] | None = None,
    sigma: float | None = None,
    adequacy: str = "scale",
) -> RTestCalibration:
    """Identify the rotary axes' errors from an R-test.

    Parameters
    ----------
    machine : Machine
    readings : (n, n_axes) ndarray
        Axis readings of the indexations (mm, rad).
    sensed : (n, k) ndarray
        Sensor readings, mm.
    sensors : Sensors
    sphere : (3,) array_like
        Nominal sphere centre, workpiece frame, mm (starting value).
    parameters : sequence of str, optional
        Candidate ISO 230-1 parameters; the rotary axes' location errors
        (:func:`~mtmetrology.rtest.model.rotary_location_candidates`) by default.  Those
        the programme cannot separate are dropped by rank and named.
    sigma : float, optional
        Standard uncertainty of one sensor reading, mm; from the residuals if omitted.
    adequacy : {"scale", "a-priori"}

    Returns
    -------
    RTestCalibration

    Raises
    ------
    InputError
        Bad shapes, names of axes the machine lacks, nothing identifiable, no redundancy.
    ConvergenceError
    """
    candidates = list(parameters) if parameters is not None else rotary_location_candidates(machine)
    full = machine.with_parameters(candidates)
    weight = sigma if sigma is not None else float(to_internal(1.0, "µm"))
    trial = RTestProblem(full, readings, sensed, sensors, sigma=weight, sphere=sphere)
    _, jac = trial.evaluate(trial.initial())
    n_p = full.n_params
    datum = choose_datum(
        np.hstack([jac[:, :n_p], jac[:, n_p:]]), candidates, nuisance=trial.nuisance
    )
    if not datum.kept:
        raise InputError(f"the R-test programme identifies none of {', '.join(candidates)}")
    m = machine.with_parameters(list(datum.kept))
    problem = RTestProblem(m, readings, sensed, sensors, sigma=weight, sphere=sphere)
    result = levenberg_marquardt(problem, xtol=XTOL, report_names=m.parameter_names)
    if not result.success:
        raise ConvergenceError(f"the R-test identification did not converge ({result.message})")
    if sigma is None:
        if result.variance_factor is None:
            raise InputError("no redundancy to estimate the sensor uncertainty: give sigma")
        result = replace(result, covariance=result.covariance * result.variance_factor)
        source = "residuals: s²(JᵀJ)⁻¹, s² = ‖r‖²/(m − n) (JCGM 100:2008, H.3)"
    else:
        result = result.with_adequacy(adequacy)
        source = f"stated σ = {from_internal(sigma, 'µm'):g} µm, adequacy rule {adequacy!r}"
    return RTestCalibration(m, problem, result, datum, source)
