"""Identification of a machine's error functions and the tracker pose from tracker readings.

Measurement model (:mod:`mtmetrology.tracker.model`): tracker-frame points
``p_LT,i = Rᵀ(f(q_i', t_i; θ) − T)`` with ``q_i' = q_i·(1 + α_q·(T_q,i − 20 °C))`` the
commanded readings corrected for the thermal expansion of the axis scales with the nominal
CTEs and the recorded temperatures (eqs 7–13).  Inputs and their uncertainties:

- tracker readings: range, azimuth, elevation (:class:`TrackerNoise`, J Σ Jᵀ per point);
- the SMR centring (isotropic);
- the axis repeatability and control noise, the CTE uncertainty (eq. 10) and the sensor
  uncertainty (eq. 3), propagated to each axis coordinate and through ∂f/∂q;
- the pose: an unknown, identified with θ (its uncertainty enters through the joint
  covariance); or known, either fixed or as a Gaussian prior (six pseudo-observations
  ``L⁻¹·(x_pose − pose_known)``, ``Σ_pose = L Lᵀ``).

The covariance of θ and the pose is ``(JᵀJ)⁻¹`` of the whitened problem, scaled by the
variance factor s² when the residuals contradict the noise model (the identification
engine's adequacy rule, :mod:`mtmetrology.identification.adequacy`); only the
parameters of the datum the set-up can see are identified, the others are named with
what to add to see them.  The constants the model leaves out as absorbed (degree-0 angular
terms of the tool-side axes) are checked by rank against the set-up
(:func:`~mtmetrology.tracker.model.setup_terms`): those that several laterally offset tools
expose are identified too and named (:attr:`TrackerCalibration.setup_terms`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.formatting import format_uncertainty
from mtmetrology.identification.adequacy import ModelAdequacy, residual_patterns
from mtmetrology.identification.datum import Datum, SetupTerms
from mtmetrology.identification.solver import levenberg_marquardt
from mtmetrology.io.covariance import symmetric, symmetric_covariance
from mtmetrology.kinematics.compensation import compensation_covariance
from mtmetrology.kinematics.machine import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.kinematics.tracker import (
    TrackerLimits,
    TrackerNoise,
    TrackerPose,
    cartesian,
    point_covariance,
)
from mtmetrology.tracker.model import (
    TrackerProblem,
    datum,
    mean_distance,
    register,
    setup_terms,
    suggestions,
    whitening,
)
from mtmetrology.tracker.setup import MachineConditions
from mtmetrology.tracker.simulate import TrackerMeasurements
from mtmetrology.units import from_internal, to_internal

__all__ = ["TrackerCalibration", "calibrate", "corrected_readings", "point_covariances"]

KIND = "tracker-calibration"


def corrected_readings(readings, temperatures, conditions: MachineConditions) -> np.ndarray:
    """Commanded readings corrected for the scale expansion, ``q·(1 + α·(T − 20))``, mm."""
    return readings * (1.0 + conditions.cte * (np.asarray(temperatures) - 20.0))


def point_covariances(
    machine: Machine,
    readings: np.ndarray,
    tools: np.ndarray,
    temperatures: np.ndarray,
    measured_tracker: np.ndarray,
    pose: TrackerPose,
    noise: TrackerNoise,
    conditions: MachineConditions,
) -> np.ndarray:
    """Per-point covariance (n, 3, 3) in the tracker frame, mm² (module notes)."""
    cov = point_covariance(measured_tracker, noise)
    axes = machine.evaluate(readings, tool=tools, d_axes=True).d_axes  # (n, 3, 3)
    var = conditions.axis_variances(readings, temperatures)
    cov_machine = np.einsum("nik,nk,njk->nij", axes, var, axes)
    rot = pose.rotation
    return cov + rot.T @ cov_machine @ rot


@dataclass(frozen=True, eq=False)
class TrackerCalibration:
    """Result of :func:`calibrate`.

    Attributes
    ----------
    parameters : ParameterSet
        The identified error parameters (the datum) with their covariance; ``mtm predict
        --params`` reads the result file as it is.
    pose : TrackerPose
        Identified tracker pose.
    pose_covariance : (6, 6) ndarray
        Of (D, L, H, α, β, δ), mm and rad.
    datum : Datum
        What the set-up identifies and what it cannot see.
    suggestions : list of dict
        What to add to see the rest (a second tool offset, more Z levels).
    residuals : (n, 3) ndarray
        Measured − predicted points, tracker frame, mm.
    mean_distance_initial, mean_distance_final : float
        Eq. 27 between measured points (registered into the machine frame) and the nominal
        points, and between measured points and the compensated model, mm.
    variance_factor : float or None
        ``‖r‖²/(m − n)`` of the whitened residuals (≈ 1 when the noise model is right).
    status : int
        Status of the solve (:mod:`mtmetrology.optimize`).
    message : str
    provenance : dict
    adequacy : ModelAdequacy or None
        The chi-squared test of the whitened residuals and the covariance factor applied.
    residual_patterns : dict
        RMS of the residuals by tool and per tracker-frame component.
    setup_terms : SetupTerms
        The left-out constants the set-up exposes (identified, in ``parameters``) and those
        it absorbs.
    pose_source : str
        ``"identified"``, ``"prior"`` (a known pose as prior) or ``"fixed"`` (known exactly;
        ``pose_covariance`` is then zero).
    noise_rms : float or None
        ``√(mean tr Σ_i)``: the RMS point distance the noise model alone predicts, mm; the
        residuals' RMS is near it when what remains is the readings' noise.
    correction_mean, compensated_u_mean : float or None
        Mean ‖f(q; θ̂) − f(q; 0)‖ over the measured points (what the compensation moves
        them by) and mean ``√tr(G U_θ Gᵀ)`` of the compensated points, mm.
    """

    parameters: ParameterSet
    pose: TrackerPose
    pose_covariance: np.ndarray
    datum: Datum
    suggestions: list
    residuals: np.ndarray
    mean_distance_initial: float
    mean_distance_final: float
    variance_factor: float | None
    status: int
    message: str
    provenance: dict = field(default_factory=dict)
    adequacy: ModelAdequacy | None = None
    residual_patterns: dict = field(default_factory=dict)
    setup_terms: SetupTerms = field(default_factory=SetupTerms)
    pose_source: str = "identified"
    noise_rms: float | None = None
    correction_mean: float | None = None
    compensated_u_mean: float | None = None

    @property
    def success(self) -> bool:
        return self.status > 0

    def summary(self) -> str:
        um = from_internal(1.0, "µm")
        res = np.linalg.norm(self.residuals, axis=1) * um
        lines = [
            f"tracker calibration of {self.parameters.machine}: {self.message}",
            f"  identified {len(self.parameters.names)} parameters; {self.datum.message}",
        ]
        if self.adequacy is not None:
            lines.append(f"  {self.adequacy.message}")
        if self.setup_terms.candidates:
            lines.append(f"  constants of the tool-side axes: {self.setup_terms.message}")
        if self.pose_source != "identified":
            lines.append(f"  tracker pose: known ({self.pose_source})")
        lines += [
            "  eq. 27 mean distance of the measured points (tracker readings, noise included): "
            f"{self.mean_distance_initial * um:.1f} µm to the nominal machine, "
            f"{self.mean_distance_final * um:.1f} µm to the compensated one",
            f"  residuals (measured - compensated model): RMS {np.sqrt(np.mean(res**2)):.1f} µm, "
            f"max {res.max():.1f} µm",
        ]
        if self.noise_rms is not None:
            lines.append(
                f"    the noise model alone predicts RMS {self.noise_rms * um:.1f} µm: "
                "residuals near it are the readings' noise, not the machine"
            )
        if self.correction_mean is not None and self.compensated_u_mean is not None:
            u = format_uncertainty(self.compensated_u_mean * um)
            lines.append(
                f"  the compensated model differs from the nominal by "
                f"{self.correction_mean * um:.1f} µm on average at the measured points; "
                f"u of a compensated point {u} µm (k = 1, from U_θ)"
            )
        for s in self.suggestions:
            if s["identifiable_then"]:
                lines.append(f"  add {s['add']}: also {', '.join(s['identifiable_then'])}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        doc = self.parameters.to_document()
        doc["kind"] = KIND
        u = np.sqrt(np.diag(self.pose_covariance))
        doc.update(
            {
                "pose": self.pose.to_dict(),
                "pose_u": dict(
                    zip(
                        ("D_mm", "L_mm", "H_mm", "alpha_deg", "beta_deg", "delta_deg"),
                        [*u[:3].tolist(), *from_internal(u[3:], "°").tolist()],
                        strict=True,
                    )
                ),
                "pose_covariance_mm_rad": symmetric(self.pose_covariance).tolist(),
                "datum": self.datum.to_dict(),
                "suggestions": self.suggestions,
                "residuals_um": from_internal(self.residuals, "µm").tolist(),
                "mean_distance_initial_um": from_internal(self.mean_distance_initial, "µm"),
                "mean_distance_final_um": from_internal(self.mean_distance_final, "µm"),
                "variance_factor": self.variance_factor,
                "status": self.status,
                "message": self.message,
                "calibration_provenance": self.provenance,
                "residual_patterns": self.residual_patterns,
                "setup_terms": self.setup_terms.to_dict(),
                "pose_source": self.pose_source,
                "noise_rms_um": _um_or_none(self.noise_rms),
                "correction_mean_um": _um_or_none(self.correction_mean),
                "compensated_u_mean_um": _um_or_none(self.compensated_u_mean),
            }
        )
        if self.adequacy is not None:
            doc["adequacy"] = self.adequacy.to_dict()
        return doc

    @classmethod
    def from_dict(cls, doc: dict, machine: Machine) -> TrackerCalibration:
        pset = ParameterSet.from_document(doc, machine, "tracker calibration")
        pset = ParameterSet(
            pset.names, pset.values, pset.units, pset.covariance, pset.provenance,
            machine=doc["machine"], model=doc.get("model"),
        )  # fmt: skip
        return cls(
            pset,
            TrackerPose.from_dict(doc["pose"]),
            symmetric_covariance(
                doc["pose_covariance_mm_rad"], "tracker calibration: pose_covariance_mm_rad"
            ),
            Datum.from_dict(doc["datum"]),
            list(doc["suggestions"]),
            _to_mm(doc["residuals_um"]),
            _to_mm(doc["mean_distance_initial_um"]),
            _to_mm(doc["mean_distance_final_um"]),
            doc["variance_factor"],
            int(doc["status"]),
            doc["message"],
            dict(doc.get("calibration_provenance", {})),
            None if "adequacy" not in doc else ModelAdequacy.from_dict(doc["adequacy"]),
            dict(doc.get("residual_patterns", {})),
            SetupTerms.from_dict(doc["setup_terms"]) if "setup_terms" in doc else SetupTerms(),
            doc.get("pose_source", "identified"),
            *(
                None if doc.get(k) is None else float(_to_mm(doc[k]))
                for k in ("noise_rms_um", "correction_mean_um", "compensated_u_mean_um")
            ),
        )


def _to_mm(value):
    return to_internal(np.asarray(value, dtype=float), "µm")


def _um_or_none(value: float | None) -> float | None:
    return None if value is None else float(from_internal(value, "µm"))


def calibrate(
    machine: Machine,
    measurements: TrackerMeasurements,
    *,
    noise: TrackerNoise | None = None,
    conditions: MachineConditions | None = None,
    limits: TrackerLimits | None = None,
    adequacy: str = "scale",
    pose: TrackerPose | None = None,
    pose_covariance: np.ndarray | None = None,
) -> TrackerCalibration:
    """Identify the error functions and the tracker pose from tracker readings.

    Parameters
    ----------
    machine : Machine
        The machine with its candidate error model (all 21 functions of the preset).
    measurements : TrackerMeasurements
    noise : TrackerNoise, optional
        The tracker's noise model (weights); the paper's values by default.
    conditions : MachineConditions, optional
        CTEs and their uncertainties, sensor uncertainty, repeatability (weights and the
        thermal correction); 11.5 µm/(m·K) and eq. 10 by default.
    limits : TrackerLimits, optional
        Readings beyond them are refused.
    adequacy : {"scale", "a-priori"}
        The identification engine's model-adequacy rule: when the whitened residuals
        contradict the noise model (chi-squared p < 0.01) the covariance is scaled by s²
        (``"scale"``) or kept (``"a-priori"``).
    pose : TrackerPose, optional
        A known tracker pose (in the machine frame of the model, see the tracker docs):
        fixed when ``pose_covariance`` is None, a Gaussian prior otherwise.  Identified
        with θ when omitted (starting from the registration, eqs 25–26).
    pose_covariance : (6, 6) array_like, optional
        Covariance of the known pose's (D, L, H, α, β, δ), mm² and rad².

    Returns
    -------
    TrackerCalibration

    Raises
    ------
    InputError
        A reading beyond the tracker's limits; a pose covariance without a pose, not 6 × 6
        or not positive definite.
    RankDeficientError
        Never for the datum chosen here (it is full rank by construction).
    """
    noise = noise or TrackerNoise()
    conditions = conditions or MachineConditions()
    (limits or TrackerLimits()).check(measurements.spherical, "measurement")
    prior = _pose_prior(pose, pose_covariance)
    fixed = pose is not None and prior is None
    q = corrected_readings(measurements.readings, measurements.temperatures, conditions)
    tools = measurements.tools
    measured = cartesian(measurements.spherical)
    nominal = machine.forward(q, tool=tools)
    start = register(nominal, measured) if pose is None else pose
    # the datum is a property of the set-up: the commanded mesh (the thermal correction
    # would make three Z levels look like more, and a cubic look observable)
    chosen = datum(machine, measurements.readings, tools, start, fixed_pose=fixed)
    terms = setup_terms(machine, chosen, measurements.readings, tools, start, fixed_pose=fixed)
    identified = machine.with_parameters([*chosen.kept, *terms.added])
    cov = point_covariances(
        machine, q, tools, measurements.temperatures, measured, start, noise, conditions
    )
    problem = TrackerProblem(identified, q, tools, measured, whitening(cov), start, fixed, prior)
    result = levenberg_marquardt(problem, report_names=identified.parameter_names)
    result = result.with_adequacy(adequacy)
    n = identified.n_params
    predicted, _ = problem.model(result.estimate, jacobian=False)
    mesh_points = np.unique(measurements.readings, axis=0)
    provenance = {"measurements": measurements.provenance, "noise": noise.to_dict()}
    tool_ids = [",".join(f"{v:g}" for v in t) for t in tools]
    patterns = residual_patterns(
        measured - predicted,
        {"tool": tool_ids},
        # the whitened residuals of the points (a pose prior appends its own six rows)
        weighted=result.residuals[: measured.size].reshape(-1, 3),
    )
    parameters = result.parameter_set(identified, {"method": "tracker volumetric verification"})
    points, point_cov = compensation_covariance(
        identified, q, parameters.values, parameters.covariance, tool=tools
    )
    return TrackerCalibration(
        parameters=parameters,
        pose=problem.pose_of(result.estimate),
        pose_covariance=np.zeros((6, 6)) if fixed else result.covariance[n:, n:],
        datum=chosen,
        suggestions=suggestions(
            machine, mesh_points, np.unique(tools, axis=0), start, chosen, fixed
        ),
        residuals=measured - predicted,
        mean_distance_initial=mean_distance(start.to_machine(measured), nominal),
        mean_distance_final=mean_distance(measured, predicted),
        variance_factor=result.variance_factor,
        status=result.status,
        message=result.message,
        provenance=provenance,
        adequacy=result.adequacy,
        residual_patterns=patterns,
        setup_terms=terms,
        pose_source="identified" if pose is None else ("fixed" if fixed else "prior"),
        noise_rms=float(np.sqrt(np.mean(np.trace(cov, axis1=1, axis2=2)))),
        correction_mean=mean_distance(points, nominal),
        compensated_u_mean=float(np.mean(np.sqrt(np.trace(point_cov, axis1=1, axis2=2)))),
    )


def _pose_prior(pose: TrackerPose | None, covariance) -> np.ndarray | None:
    """``L⁻¹`` of a known pose's covariance (None: no prior)."""
    if covariance is None:
        return None
    if pose is None:
        raise InputError("pose covariance: given without a known pose")
    c = np.asarray(covariance, dtype=float)
    if c.shape != (6, 6) or not np.all(np.isfinite(c)):
        raise InputError(f"pose covariance: must be a finite 6 x 6 matrix, got shape {c.shape}")
    try:
        return np.linalg.inv(np.linalg.cholesky(0.5 * (c + c.T)))
    except np.linalg.LinAlgError:
        raise InputError("pose covariance: not positive definite") from None
