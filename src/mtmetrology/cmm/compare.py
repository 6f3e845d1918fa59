"""Kinematic versus GP error model on held-out plate positions of a virtual CMM.

The comparison the source intended (Salacheep 2016, Ch. 7, Table 7.1), done on data the fits
never saw and against a known truth: for every pair of balls probed with the same stylus in
a held-out position, the compensated length ``‖p_a − p_b‖`` is compared with the true length
``‖c_a − c_b‖``.  Lengths do not depend on the frame in which each model states its
coordinates (its datum), so the two models are compared on equal terms.  Each model's
standard uncertainty of the length is ``u² = gᵀ (V_a + V_b − 2 C_ab) g + 2σ²`` with ``g`` the
unit vector, ``V``, ``C`` the model covariances of the two compensated points and ``σ`` the
reading noise; coverage is the fraction of pairs with ``|error| ≤ k u``, k = 2.

The source's percentage error (eq. 7.1) divides by the error itself and is not used; its
Table 7.1 cannot be derived from its own Appendix 4 (digest of Salacheep 2016, §3.7).

References
----------
Salacheep, P. (2016). *Error Compensation and Uncertainty Evaluation of CMMs Based on
Kinematic Error Models and Gaussian Processes*. MPhil thesis, Brunel University London,
Ch. 7.
JCGM 100:2008, §5.2.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mtmetrology.cmm.calibrate import calibrate_ballplate
from mtmetrology.cmm.files import BallPlate, ProbeSet
from mtmetrology.cmm.gp import fit_gp
from mtmetrology.cmm.notebook import CMMNotebookRepr
from mtmetrology.cmm.simulate import SimulatedCampaign
from mtmetrology.kinematics.machine import Machine
from mtmetrology.uncertainty.coverage import DEFAULT_K
from mtmetrology.units import from_internal

__all__ = ["ModelComparison", "compare_models", "length_errors"]

COVERAGE_FACTOR = DEFAULT_K  # the coverage policy (mtmetrology.uncertainty.coverage)


def _pairs(n: int) -> tuple[np.ndarray, np.ndarray]:
    a, b = np.triu_indices(n, 1)
    return a, b


def length_errors(points, true_points, cov_xyz, sigma):
    """Length errors and their standard uncertainty for all pairs of a group of points.

    Parameters
    ----------
    points, true_points : ndarray (n, 3)
        Compensated and true centres, mm.
    cov_xyz : ndarray (3, n, n)
        Model covariance of the compensated coordinates per component, mm² (components
        uncorrelated).
    sigma : float
        Reading noise, mm.

    Returns
    -------
    true_length, error, u : ndarray (n_pairs,), mm
    """
    a, b = _pairs(len(points))
    d = points[a] - points[b]
    length = np.linalg.norm(d, axis=1)
    true_length = np.linalg.norm(true_points[a] - true_points[b], axis=1)
    g = d / length[:, None]
    var = np.zeros(len(a))
    for c in range(3):
        cv = cov_xyz[c]
        var += g[:, c] ** 2 * (cv[a, a] + cv[b, b] - 2.0 * cv[a, b])
    return true_length, length - true_length, np.sqrt(var + 2.0 * sigma**2)


@dataclass(frozen=True)
class ModelComparison(CMMNotebookRepr):
    """Table and plot data of :func:`compare_models`.

    Attributes
    ----------
    table : list of dict
        One row per model: ``model, n_lengths, rms_error_um, max_error_um,
        mean_u_um, coverage, coverage_factor``.
    plot : dict
        ``{model: {"length_mm", "error_um", "u_um"}}`` for a plot of length error against
        length with ±k·u bands.
    gp_at_bounds : list of dict
        The GP's hyper-parameters that ended at a bound of their search range
        (:attr:`~mtmetrology.cmm.gp.GPErrorModel.at_bounds`); empty when all are interior.
    """

    table: list
    plot: dict
    gp_at_bounds: list = field(default_factory=list)

    def to_dict(self) -> dict:
        return {
            "kind": "cmm-model-comparison",
            "version": 1,
            "table": self.table,
            "plot": self.plot,
            "gp_at_bounds": self.gp_at_bounds,
        }


def length_error_row(model: str, errors: np.ndarray, u: np.ndarray) -> dict:
    """One row of a model comparison: RMS and largest length error, mean u (µm), and the
    fraction of lengths with |error| ≤ k·u (k = :data:`COVERAGE_FACTOR`); errors and u in mm."""
    e_um, u_um = from_internal(errors, "µm"), from_internal(u, "µm")
    return {
        "model": model,
        "n_lengths": int(errors.size),
        "rms_error_um": float(np.sqrt(np.mean(e_um**2))),
        "max_error_um": float(np.max(np.abs(e_um))),
        "mean_u_um": float(np.mean(u_um)),
        "coverage": float(np.mean(np.abs(errors) <= COVERAGE_FACTOR * u)),
        "coverage_factor": COVERAGE_FACTOR,
    }


def compare_models(
    base: Machine,
    campaign: SimulatedCampaign,
    plate: BallPlate,
    probes: ProbeSet,
    held_out: str,
    *,
    sigma: float,
    kinematic_model: str = "full-3",
    gp_mean: str | None = "seed",
    kernel: str = "rbf",
) -> ModelComparison:
    """Fit both models without one position; judge them on its lengths against the truth.

    Parameters
    ----------
    base : Machine
    campaign : SimulatedCampaign
        Records with their true machine-frame centres.
    plate, probes
    held_out : str
        Position id left out of both fits.
    sigma : float
        Reading noise, mm.
    kinematic_model, gp_mean, kernel
        The kinematic model, and the GP's mean model and kernel.

    Returns
    -------
    ModelComparison
    """
    rec = campaign.records
    test = np.array([p == held_out for p in rec.positions])
    if not test.any():
        raise ValueError(f"position {held_out!r} is not in the records")
    train = rec.subset(~test)
    kin = calibrate_ballplate(base, train, plate, probes, model=kinematic_model, sigma=sigma)
    gp = fit_gp(base, train, plate, probes, sigma=sigma, mean=gp_mean, kernel=kernel)
    held = rec.subset(test)
    truth = campaign.true_points[test]
    tools = probes.offsets(held.probes)
    out_rows, plot = [], {}
    for name in ("uncompensated", f"kinematic {kinematic_model}", f"GP ({kernel})"):
        lengths, errs, us = [], [], []
        for pid in dict.fromkeys(held.probes):
            s = np.array([p == pid for p in held.probes])
            q, t = held.readings[s], tools[s]
            n = int(s.sum())
            if name == "uncompensated":
                pts, cov = base.with_parameters([]).forward(q, None, tool=t), np.zeros((3, n, n))
            elif name.startswith("kinematic"):
                pts = kin.compensate(q, t)
                jac = kin.machine.jacobian(q, kin.theta, tool=t)
                cov = np.stack(
                    [jac[:, c, :] @ kin.parameters.covariance @ jac[:, c, :].T for c in range(3)]
                )
            else:
                pts, _, cov = gp.predict(q, t, return_cov=True)
            L, e, u = length_errors(pts, truth[s], cov, sigma)
            lengths.append(L)
            errs.append(e)
            us.append(u)
        L, e, u = (np.concatenate(v) for v in (lengths, errs, us))
        e_um, u_um = from_internal(e, "µm"), from_internal(u, "µm")
        out_rows.append(length_error_row(name, e, u))
        plot[name] = {"length_mm": L.tolist(), "error_um": e_um.tolist(), "u_um": u_um.tolist()}
    return ModelComparison(out_rows, plot, [f.to_dict() for f in gp.at_bounds])
