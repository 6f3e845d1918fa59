"""cov(e) from data: the unexplained volumetric error estimated from compensated residuals.

Sepahi Boroujeni (2021), eqs. 6-13 to 6-15, writes the compensated residuals of a
calibration's positions as e_s = q_s − d_s (the compensated position of an indication
minus the identified position it should have reached) and takes their covariance as
cov(e), the ``unexplained_volumetric_error`` group of the task model
(:mod:`mtmetrology.omm.task`). The thesis states the result (eq. 6-15, 92 positions) but
not the estimator; this module states it.

Estimator (method of moments). For residuals r_s, s = 1 … n, of a least-squares fit with
p unknowns, E[Σ_s r_s r_sᵀ] ≈ (n − p/3)·C_r when the fit's lost degrees of freedom are
shared equally by the three coordinates (exact for an isotropic C_r); the residuals also
carry the indication noise Σ_v the calibration stated, which the task model already holds
in its ``repeatability`` group. Hence

    Ĉ = Σ_s (r_s − r̄·[centred]) (r_s − r̄·[centred])ᵀ / ν − Σ_v,    ν = n − p/3 (− 1 centred),

made positive semidefinite by eigenvalue clipping, Ĉ₊ = V max(Λ, 0) Vᵀ, the nearest PSD
matrix in the Frobenius norm (Higham 1988). Residuals held out of the fit are not shrunk
by it: give ``fitted_parameters=0``. The sampling standard uncertainty of each element
(normal residuals, Wishart with ν degrees of freedom) is u(Ĉ_ij) = √((C_ii C_jj + C_ij²)/ν).

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, §6.3.3, eqs. 6-13 to 6-15.

Higham, N. J. (1988). Computing a nearest symmetric positive semidefinite matrix.
*Linear Algebra and its Applications* 103, 103–118.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.io.covariance import symmetric
from mtmetrology.units import from_internal, to_internal

__all__ = ["UnexplainedCovariance", "estimate_unexplained_covariance"]

KIND = "unexplained-volumetric-error"


def _um2(c: np.ndarray) -> np.ndarray:
    return c / float(to_internal(1.0, "µm")) ** 2


@dataclass(frozen=True)
class UnexplainedCovariance:
    """cov(e) estimated from residuals, with the estimator's terms.

    Attributes
    ----------
    covariance : (3, 3) ndarray, mm²
        Ĉ₊, positive semidefinite: what the task model adds to every point.
    raw : (3, 3) ndarray, mm²
        Ĉ before clipping (residual covariance minus the indication noise).
    mean : (3,) ndarray, mm
        r̄, the mean residual (≈ 0 for a least-squares fit with free positions).
    n_residuals : int
        n positions.
    fitted_parameters : int
        p unknowns fitted to the residuals (0 for held-out positions).
    degrees_of_freedom : float
        ν of the estimate.
    noise_covariance : (3, 3) ndarray, mm²
        Σ_v removed (the indication noise already in the repeatability group).
    standard_uncertainty : (3, 3) ndarray, mm²
        u(Ĉ_ij) = √((Ĉ_ii Ĉ_jj + Ĉ_ij²)/ν) of each element.
    source : str
        Where the residuals came from.
    """

    covariance: np.ndarray
    raw: np.ndarray
    mean: np.ndarray
    n_residuals: int
    fitted_parameters: int
    degrees_of_freedom: float
    noise_covariance: np.ndarray
    standard_uncertainty: np.ndarray
    source: str = ""

    @property
    def u(self) -> np.ndarray:
        """(3,) standard uncertainties of e_x, e_y, e_z, mm: √diag(Ĉ)."""
        return np.sqrt(np.diag(self.covariance))

    @property
    def clipped(self) -> bool:
        """Whether eigenvalue clipping changed Ĉ (it had a negative eigenvalue)."""
        return bool(np.linalg.eigvalsh(self.raw)[0] < 0)

    def to_dict(self) -> dict:
        """The ``unexplained-volumetric-error`` document (µm²) that ``mtm task uncertainty
        --unexplained`` reads, with the estimator under ``estimate``."""
        return {
            "kind": KIND,
            "version": 1,
            "unit": "µm²",
            # exactly symmetric: the eigenvalue clipping leaves rounding asymmetry
            "covariance": _um2(symmetric(self.covariance)).tolist(),
            "source": self.source,
            "estimate": {
                "estimator": "Σ r rᵀ / ν − Σ_v, ν = n − p/3 (− 1 if centred); "
                "eigenvalues clipped at 0 (nearest PSD, Higham 1988)",
                "n_residuals": self.n_residuals,
                "fitted_parameters": self.fitted_parameters,
                "degrees_of_freedom": self.degrees_of_freedom,
                "mean_um": from_internal(self.mean, "µm").tolist(),
                "raw": _um2(self.raw).tolist(),
                "noise_covariance": _um2(self.noise_covariance).tolist(),
                "standard_uncertainty": _um2(self.standard_uncertainty).tolist(),
                "clipped": self.clipped,
            },
        }

    @classmethod
    def from_dict(cls, doc: dict) -> UnexplainedCovariance:
        """Inverse of :meth:`to_dict`."""
        est = doc["estimate"]
        um = float(to_internal(1.0, "µm"))
        return cls(
            np.array(doc["covariance"], float) * um * um,
            np.array(est["raw"], float) * um * um,
            np.array(est["mean_um"], float) * um,
            int(est["n_residuals"]),
            int(est["fitted_parameters"]),
            float(est["degrees_of_freedom"]),
            np.array(est["noise_covariance"], float) * um * um,
            np.array(est["standard_uncertainty"], float) * um * um,
            doc.get("source") or "",
        )


def estimate_unexplained_covariance(
    residuals: np.ndarray,
    *,
    fitted_parameters: int = 0,
    noise_covariance: np.ndarray | None = None,
    centred: bool = False,
    source: str = "",
) -> UnexplainedCovariance:
    """Estimate cov(e) from compensated residuals (module notes give the estimator).

    Parameters
    ----------
    residuals : (n, 3) array, mm
        r_s = f(φ_s, δ̂) − d̂_s, compensated position minus the position it should have
        reached (e.g. :attr:`mtmetrology.samba.SambaCalibration.residual_vectors`); the
        sign does not enter Ĉ.
    fitted_parameters : int
        p, unknowns the residuals were fitted with (machine parameters, ball centres,
        tool); 0 for positions held out of the fit.
    noise_covariance : (3, 3) array or float, mm², optional
        Σ_v, the indication noise the residuals carry and the task's repeatability group
        already holds; removed from the estimate. None: nothing removed.
    centred : bool
        Subtract the mean residual (one more degree of freedom lost); by default the
        model's mean ē = 0 is used, as in eq. 6-14.
    source : str
        Provenance written into the document.

    Returns
    -------
    UnexplainedCovariance

    Raises
    ------
    InputError
        Residuals not (n, 3) or not finite, ν ≤ 0, a noise covariance not 3×3.

    Examples
    --------
    >>> r = np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 2.0, 0], [0, -2.0, 0]]) * 1e-3
    >>> e = estimate_unexplained_covariance(r)
    >>> np.round(np.diag(e.covariance) * 1e6, 3).tolist()   # µm²: (1+1)/4, (4+4)/4, 0
    [0.5, 2.0, 0.0]
    """
    r = np.asarray(residuals, float)
    if r.ndim != 2 or r.shape[1] != 3:
        raise InputError(f"residuals: expected an (n, 3) array, got shape {r.shape}")
    if not np.all(np.isfinite(r)):
        raise InputError("residuals: not finite")
    if fitted_parameters < 0:
        raise InputError(f"fitted_parameters: must be >= 0, got {fitted_parameters}")
    n = r.shape[0]
    nu = n - fitted_parameters / 3.0 - (1.0 if centred else 0.0)
    if nu <= 0:
        raise InputError(
            f"residuals: {n} positions leave no degrees of freedom after "
            f"{fitted_parameters} fitted parameters"
        )
    mean = r.mean(axis=0)
    d = r - mean if centred else r
    sigma_v = np.zeros((3, 3)) if noise_covariance is None else np.asarray(noise_covariance, float)
    if sigma_v.ndim == 0:  # a variance: isotropic noise σ² I
        sigma_v = sigma_v * np.eye(3)
    if sigma_v.shape != (3, 3):
        raise InputError(f"noise_covariance: expected 3×3, got shape {sigma_v.shape}")
    raw = d.T @ d / nu - sigma_v
    raw = 0.5 * (raw + raw.T)
    lam, vec = np.linalg.eigh(raw)
    psd = (vec * np.maximum(lam, 0.0)) @ vec.T
    psd = 0.5 * (psd + psd.T)  # exactly symmetric (the file form is checked for it)
    diag = np.diag(psd)
    u = np.sqrt((np.outer(diag, diag) + psd**2) / nu)
    return UnexplainedCovariance(
        psd, raw, mean, n, int(fitted_parameters), float(nu), sigma_v, u, source
    )
