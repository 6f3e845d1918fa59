"""Design criteria of an identification: D-, A-, E-optimality and the indices O1–O5.

A calibration design (which balls, which indexations) fixes the rows of the weighted
identification Jacobian ``J`` (:class:`mtmetrology.identification.BallCentreProblem`),
hence its information matrix ``F = JᵀJ``. Two families of criteria, all maximised:

=====  =====================================  ============================================
name   value                                  on
=====  =====================================  ============================================
D      ``log det F = Σ log λ_i``              ``F`` in a fixed column scaling (the design
A      ``−trace F⁻¹ = −Σ 1/λ_i``              routines use the scaling that gives the whole
E      ``λ_min``                              candidate set a unit diagonal)
O1–O5  observability indices, Alami           the per-design **column-scaled** ``F_s =
       Mchichi (2018) eqs 5.9–5.13            D⁻¹ F D⁻¹``, ``D² = diag F``: σ_i² = λ_i(F_s)
=====  =====================================  ============================================

The classical criteria (D: volume of the confidence ellipsoid; A: sum of the variances;
E: the worst direction) compare designs at *fixed* parameter units: D is invariant to any
fixed scaling, A and E are then unit-free. The observability indices use the Jacobian
with unit-norm columns of each design, as the source and the identifiability diagnostics
(:func:`~mtmetrology.identification.analyse_identifiability`, ``mtm machine
identifiability``) do, so the condition number a design promises is the one the
identifiability check prints for the programme. Normalising per design changes the
D-optimum (it divides det F by Π diag F), which is why D, A and E do not.

A rank-deficient design has no value (``−inf``): every full-rank design beats it.

References
----------
Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes : configuration
optimisée des artefacts et de la séquence de mesure de la méthode SAMBA en vue d'une
estimation efficace des erreurs géométriques*. PhD thesis, École Polytechnique de
Montréal, §5.4 (O1–O5), eqs 5.19 and 6.14 (UPF).
Atkinson, A. C., Donev, A. N., Tobias, R. D. (2007). *Optimum Experimental Designs, with
SAS*. Oxford University Press, ch. 10 (D-, A-, E-optimality).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from mtmetrology.design.choices import CRITERIA
from mtmetrology.errors import InputError

__all__ = [
    "check_criterion",
    "criterion_from_spectrum",
    "scaled_spectrum",
    "uncertainty_propagation_factors",
]


#: Eigenvalues of the column-scaled information matrix below RANK_RTOL · λ_max count as
#: zero: the rank tolerance of the diagnostics (1e-8 on σ) squared.
RANK_RTOL = 1e-16


def check_criterion(name: str) -> str:
    """The canonical criterion name, or an :class:`InputError` naming the choices.

    >>> check_criterion("d"), check_criterion("O2")
    ('D', 'O2')
    """
    key = str(name).strip().upper()
    if key not in CRITERIA:
        raise InputError(f"unknown design criterion {name!r}: choose one of {', '.join(CRITERIA)}")
    return key


def scaled_spectrum(information: np.ndarray) -> np.ndarray:
    """Eigenvalues (ascending) of the column-scaled information matrix(es).

    Parameters
    ----------
    information : ndarray, shape (..., n, n)
        ``JᵀJ`` (symmetric positive semi-definite), any column units.

    Returns
    -------
    ndarray, shape (..., n)
        Eigenvalues of ``D⁻¹ F D⁻¹``, ``D = sqrt(diag F)``: the squared singular values of
        the Jacobian scaled to unit-norm columns.
    """
    f = np.asarray(information, dtype=float)
    d = np.sqrt(np.einsum("...ii->...i", f))
    d = np.where(d > 0, d, 1.0)
    return np.linalg.eigvalsh(f / d[..., :, None] / d[..., None, :])


def criterion_from_spectrum(
    criterion: str, eigenvalues: np.ndarray, n_measurements: int | np.ndarray = 1
) -> np.ndarray:
    """Value of a criterion from scaled eigenvalues (larger is better).

    Parameters
    ----------
    criterion : str
        One of :data:`~mtmetrology.design.choices.CRITERIA`.
    eigenvalues : ndarray, shape (..., n)
        Eigenvalues of the information matrix, ascending: column-scaled per design
        (:func:`scaled_spectrum`) for O1–O5, in the fixed scaling for D, A, E.
    n_measurements : int or ndarray, shape (...)
        Number of measurements m (enters O1 only).

    Returns
    -------
    ndarray, shape (...)
        ``−inf`` where the design is rank deficient.

    Examples
    --------
    >>> lam = np.array([1.0, 4.0, 16.0])      # singular values 1, 2, 4
    >>> float(criterion_from_spectrum("O2", lam)), float(criterion_from_spectrum("A", lam))
    (0.25, -1.3125)
    """
    key = check_criterion(criterion)
    lam = np.asarray(eigenvalues, dtype=float)
    top = lam[..., -1]
    deficient = lam[..., 0] <= RANK_RTOL * np.where(top > 0, top, 1.0)
    safe = np.where(deficient[..., None], 1.0, lam)
    if key == "D":
        value = np.sum(np.log(safe), axis=-1)
    elif key == "A":
        value = -np.sum(1.0 / safe, axis=-1)
    elif key == "E":
        value = safe[..., 0]
    else:
        s = np.sqrt(safe)
        smin, smax = s[..., 0], s[..., -1]
        value = {
            "O1": lambda: np.exp(np.mean(np.log(s), axis=-1)) / np.sqrt(n_measurements),
            "O2": lambda: smin / smax,
            "O3": lambda: smin,
            "O4": lambda: smin**2 / smax,
            "O5": lambda: 1.0 / np.sum(1.0 / s, axis=-1),
        }[key]()
    return np.where(deficient, -np.inf, value)


def uncertainty_propagation_factors(
    jacobian: np.ndarray, names: Sequence[str] | None = None
) -> np.ndarray:
    """Uncertainty propagation factor of every unknown, ``sqrt(diag((JᵀJ)⁻¹))``.

    Parameters
    ----------
    jacobian : ndarray, shape (n_rows, n)
        Identification Jacobian with rows divided by the standard uncertainty of each
        observation (weighted), or unweighted.
    names : sequence of str, optional
        Used only to name a column in the error message.

    Returns
    -------
    ndarray, shape (n,)
        With weighted rows: the predicted standard uncertainty of each unknown, in its
        internal unit (mm, rad, 1). With unweighted rows: uncertainty per unit input noise.

    Raises
    ------
    RankDeficientError
        If ``JᵀJ`` is singular.

    Notes
    -----
    Alami Mchichi (2018), eq. 6.14 (Olarra et al. 2018): ``UPF_i = sqrt(diag((JᵀJ)⁻¹))_i``,
    and eq. 5.19 the mean over the unknowns. **Unit caveat**: each UPF carries the unit
    of its unknown per unit of the observations (µm/µm, µrad/µm, (µm/m)/µm); a mean over
    parameters of mixed units (the source's ``UPF_test``) depends on the units chosen and
    is only comparable between designs at fixed units and fixed parameter list. The design
    reports give the per-parameter values in customary units and the mean only per unit
    group.

    Examples
    --------
    >>> j = np.diag([2.0, 4.0])
    >>> uncertainty_propagation_factors(j).tolist()
    [0.5, 0.25]
    """
    from mtmetrology.errors import RankDeficientError

    j = np.asarray(jacobian, dtype=float)
    info = j.T @ j
    norms = np.sqrt(np.diag(info))
    norms = np.where(norms > 0, norms, 1.0)
    scaled = info / norms[:, None] / norms[None, :]
    lam = np.linalg.eigvalsh(scaled)
    if lam[0] <= 1e-16 * lam[-1]:
        label = "" if names is None else f" ({len(tuple(names))} unknowns)"
        raise RankDeficientError(
            f"the design is rank deficient{label}: no propagation factor; add measurements"
        )
    cov = np.linalg.inv(scaled) / norms[:, None] / norms[None, :]
    return np.sqrt(np.diag(cov))
