"""Kinematic against GP error model on held-out plate positions of real records.

Measurement model, for every pair (a, b) of balls probed with the same stylus in a plate
position that neither fit saw::

    E_ab = ‖p̂_a − p̂_b‖ − ‖c_a − c_b‖
    u²(E_ab) = gᵀ(V_a + V_b − 2C_ab)g + 2σ² + g_cᵀ(P_a + P_b − P_ab − P_ba)g_c

``p̂`` the model's compensated centre (its covariance blocks ``V, C`` from the kinematic
parameter covariance or the GP's predictive covariance), ``c`` the certificate centres of
the plate with their covariance ``P`` (the only reference: no truth is needed, as with a
real CMM), ``g``, ``g_c`` the unit vectors of the two lengths, ``σ`` the standard
uncertainty of a reading coordinate.  Lengths do not depend on the frame in which each
model states its coordinates, so the kinematic model (least squares, Chebyshev error
functions) and the GP (Salacheep 2016, Ch. 5) are compared on equal terms; the coverage is
the fraction of lengths with ``|E| ≤ k u``, k = 2.  This replaces the source's percentage
error (eq. 7.1), which divides by the error itself.

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
from mtmetrology.cmm.compare import length_error_row, length_errors
from mtmetrology.cmm.files import BallPlate, BallPlateRecords, ProbeSet
from mtmetrology.cmm.gp import fit_gp
from mtmetrology.cmm.notebook import CMMNotebookRepr
from mtmetrology.errors import InputError
from mtmetrology.kinematics.machine import Machine
from mtmetrology.uncertainty.coverage import DEFAULT_K
from mtmetrology.units import from_internal

__all__ = ["HeldOutComparison", "compare_held_out"]

KIND = "cmm-held-out-comparison"
VERSION = 1
COVERAGE_FACTOR = DEFAULT_K  # the coverage policy (mtmetrology.uncertainty.coverage)


@dataclass(frozen=True)
class HeldOutComparison(CMMNotebookRepr):
    """Result of :func:`compare_held_out`.

    Attributes
    ----------
    held_out : tuple of str
        Plate positions left out of both fits.
    table : list of dict
        One row per model: ``model, n_lengths, rms_error_um, max_error_um, mean_u_um,
        coverage, coverage_factor``.
    plot : dict
        ``{model: {"length_mm", "error_um", "u_um"}}``.
    settings : dict
        ``kinematic_model, gp_mean, kernel, sigma_um``.
    provenance : dict
    """

    held_out: tuple
    table: list
    plot: dict
    settings: dict
    provenance: dict = field(default_factory=dict)

    def row(self, model: str) -> dict:
        """The table row of ``model`` (``uncompensated``, ``kinematic``, ``GP``)."""
        for r in self.table:
            if r["model"].split(" ")[0] == model:
                return r
        raise KeyError(model)

    def to_dict(self) -> dict:
        """File form (version 1)."""
        return {
            "kind": KIND,
            "version": VERSION,
            "held_out": list(self.held_out),
            "settings": self.settings,
            "table": self.table,
            "plot": self.plot,
            "provenance": self.provenance,
        }

    @classmethod
    def from_dict(cls, doc: dict) -> HeldOutComparison:
        """Read :meth:`to_dict`'s form back."""
        if doc.get("kind") != KIND or doc.get("version") != VERSION:
            raise InputError(f"comparison: expected kind {KIND!r} version {VERSION}")
        return cls(
            tuple(doc["held_out"]),
            list(doc["table"]),
            dict(doc["plot"]),
            dict(doc["settings"]),
            dict(doc.get("provenance") or {}),
        )


def _plate_variance(plate: BallPlate, ids: list[str]) -> np.ndarray:
    """``g_cᵀ(P_a + P_b − P_ab − P_ba)g_c`` for all pairs of ``ids`` (triu order), mm²."""
    idx = np.array([plate.ids.index(b) for b in ids])
    c = plate.coordinates[idx]
    cov = plate.covariance.reshape(len(plate.ids), 3, len(plate.ids), 3)[idx][:, :, idx]
    a, b = np.triu_indices(len(ids), 1)
    g = c[a] - c[b]
    g /= np.linalg.norm(g, axis=1)[:, None]
    block = cov[a, :, a] + cov[b, :, b] - cov[a, :, b] - cov[b, :, a]  # (pairs, 3, 3)
    return np.einsum("pi,pij,pj->p", g, block, g)


def compare_held_out(
    base: Machine,
    records: BallPlateRecords,
    plate: BallPlate,
    probes: ProbeSet,
    held_out,
    *,
    sigma: float,
    kinematic_model="full-3",
    gp_mean: str | None = "seed",
    kernel: str = "rbf",
) -> HeldOutComparison:
    """Fit both models without the held-out positions; judge them on the plate's lengths.

    Parameters
    ----------
    base : Machine
    records : BallPlateRecords
    plate : BallPlate
        Certificate centres and covariance: the reference lengths.
    probes : ProbeSet
    held_out : sequence of str
        Position ids left out of both fits (at least one position must remain).
    sigma : float
        Standard uncertainty of a reading coordinate, mm.
    kinematic_model : str or ModelChoice
        Kinematic model (``seed``, ``full-<d>``).
    gp_mean : str or None
        The GP's kinematic mean, None for zero mean.
    kernel : {"rbf", "matern"}

    Returns
    -------
    HeldOutComparison

    Raises
    ------
    InputError
        A held-out id not in the records, or no position left to fit.
    """
    held_out = tuple(dict.fromkeys(held_out))
    for h in held_out:
        if h not in records.position_ids:
            raise InputError(
                f"--held-out {h!r}: not a position of the records "
                f"({', '.join(records.position_ids)})"
            )
    test = np.array([p in held_out for p in records.positions])
    if test.all() or not held_out:
        raise InputError("--held-out: leave at least one position to fit and hold one out")
    train = records.subset(~test)
    kin = calibrate_ballplate(base, train, plate, probes, model=kinematic_model, sigma=sigma)
    gp = fit_gp(base, train, plate, probes, sigma=sigma, mean=gp_mean, kernel=kernel)
    held = records.subset(test)
    tools = probes.offsets(held.probes)
    groups = [  # (position, probe) -> the records of its balls (one per ball)
        np.flatnonzero([(p, q) == key for p, q in zip(held.positions, held.probes, strict=True)])
        for key in dict.fromkeys(zip(held.positions, held.probes, strict=True))
    ]
    kin_name = f"kinematic {kin.model}"
    names = ("uncompensated", kin_name, f"GP ({gp_mean or 'zero'} mean, {kernel})")
    nominal = base.with_parameters([])
    rows, plot = [], {}
    for name in names:
        parts = []
        for s in groups:
            if len(s) < 2:
                continue
            q, t, n = held.readings[s], tools[s], len(s)
            if name == "uncompensated":
                pts, cov = nominal.forward(q, None, tool=t), np.zeros((3, n, n))
            elif name == kin_name:
                pts = kin.compensate(q, t)
                jac = kin.machine.jacobian(q, kin.theta, tool=t)
                v = kin.parameters.covariance
                cov = np.stack([jac[:, c, :] @ v @ jac[:, c, :].T for c in range(3)])
            else:
                pts, _, cov = gp.predict(q, t, return_cov=True)
            ids = [held.balls[i] for i in s]
            ref = plate.coordinates[[plate.ids.index(b) for b in ids]]
            length, err, u = length_errors(pts, ref, cov, sigma)
            u = np.sqrt(u**2 + _plate_variance(plate, ids))
            parts.append((length, err, u))
        length, err, u = (np.concatenate(v) for v in zip(*parts, strict=True))
        e_um, u_um = from_internal(err, "µm"), from_internal(u, "µm")
        rows.append(length_error_row(name, err, u))
        plot[name] = {
            "length_mm": length.tolist(),
            "error_um": e_um.tolist(),
            "u_um": u_um.tolist(),
        }
    settings = {
        "kinematic_model": kin.model,
        "gp_mean": gp_mean or "zero",
        "kernel": kernel,
        "sigma_um": float(from_internal(sigma, "µm")),
    }
    prov = {"reference": "plate certificate", "train_positions": list(train.position_ids)}
    return HeldOutComparison(held_out, rows, plot, settings, prov)
