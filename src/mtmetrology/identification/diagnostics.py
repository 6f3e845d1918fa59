"""Identifiability diagnostics of an identification Jacobian.

For a Jacobian ``J`` (rows: observations, columns: unknowns) the report gives the rank,
the singular values, the condition number raw (in the units of the unknowns) and with
every column scaled to unit 2-norm, the observability indices O1–O5 (Alami Mchichi (2018),
eqs 5.9–5.13), and the unidentifiable combinations written in parameter names.

Notes
-----
The rank is counted on the column-scaled Jacobian with tolerance ``rtol·σ_max``.  A
null direction ``v`` (``J_s v = 0``) says that moving the unknowns along ``v`` leaves every
prediction unchanged.  The null space is returned in reduced row-echelon form, so each
direction has one pivot unknown and as few partners as the null space allows: two
confounded parameters read ``"E_Y0C ~ E_Y0S"``; a column that is zero on its own reads
``"E_CY1 (not observable)"``.

Rank must be judged at the nominal (zero-error) point when confounding is exact there:
at perturbed errors exact null singular values become small but non-zero
(identifiability-check Q2, "Caution for test writers").

References
----------
Driels & Pathre 1990 (O2), Borm & Menq 1989 (O1), Nahvi & Hollerbach 1996 (O3, O4),
Sun & Hollerbach 2008 (O5), as quoted in Alami Mchichi (2018), eqs 5.9–5.13; O5 sums over the
unknowns, not the measurements (as Sun & Hollerbach define it; the thesis's eq. 5.13 does not say).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mtmetrology.display import NotebookRepr

__all__ = [
    "IdentifiabilityReport",
    "NullDirection",
    "analyse_identifiability",
    "observability_indices",
]


@dataclass(frozen=True)
class NullDirection:
    """One unidentifiable combination of unknowns (column-scaled coordinates).

    Attributes
    ----------
    terms : tuple of (name, coefficient)
        Unknowns with a non-negligible share, largest first; the vector has unit norm.
    """

    terms: tuple[tuple[str, float], ...]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(n for n, _ in self.terms)

    def __str__(self) -> str:
        if len(self.terms) == 1:
            return f"{self.terms[0][0]} (not observable)"
        return " ~ ".join(self.names)

    def combination(self) -> str:
        """The null combination with its coefficients, e.g. ``0.707·E_Y0C + 0.707·E_Y0S``."""
        parts = []
        for i, (n, c) in enumerate(self.terms):
            sign = "−" if c < 0 else "+"
            mag = f"{abs(c):.3g}·{n}"
            parts.append((f"−{mag}" if c < 0 else mag) if i == 0 else f" {sign} {mag}")
        return "".join(parts)


@dataclass(frozen=True)
class IdentifiabilityReport(NotebookRepr):
    """Rank and conditioning of an identification Jacobian.

    Attributes
    ----------
    names : tuple of str
        The unknowns (columns).
    rank : int
    singular_values : ndarray
        Of the column-scaled Jacobian, descending.
    singular_values_raw : ndarray
        Of the Jacobian in the internal units of the unknowns.
    condition_raw, condition_scaled : float
        ``σ_max/σ_min`` (inf when rank deficient).
    observability : dict
        O1..O5 of the column-scaled Jacobian (full rank only; else empty).
    null_directions : tuple of NullDirection
    message : str
    """

    names: tuple[str, ...]
    rank: int
    singular_values: np.ndarray
    singular_values_raw: np.ndarray
    condition_raw: float
    condition_scaled: float
    observability: dict
    null_directions: tuple[NullDirection, ...]
    column_norms: np.ndarray
    tolerance: float
    message: str

    @property
    def n_unknowns(self) -> int:
        return len(self.names)

    @property
    def full_rank(self) -> bool:
        return self.rank == self.n_unknowns

    def confounded(self) -> list[tuple[str, ...]]:
        """Names of each null direction, e.g. ``[("E_Y0C", "E_Y0S")]``."""
        return [d.names for d in self.null_directions]

    def to_dict(self) -> dict:
        return {
            "kind": "identifiability-report",
            "version": 1,
            "unknowns": list(self.names),
            "rank": self.rank,
            "n_unknowns": self.n_unknowns,
            "condition_raw": _finite_or_none(self.condition_raw),
            "condition_scaled": _finite_or_none(self.condition_scaled),
            "singular_values_scaled": self.singular_values.tolist(),
            "singular_values_raw": self.singular_values_raw.tolist(),
            "observability": self.observability,
            "null_directions": [
                {"summary": str(d), "terms": [{"name": n, "coefficient": c} for n, c in d.terms]}
                for d in self.null_directions
            ],
            "message": self.message,
        }


def _finite_or_none(x: float):
    return float(x) if np.isfinite(x) else None


def observability_indices(singular_values: np.ndarray, n_measurements: int) -> dict:
    """Observability indices O1–O5 of a full-rank Jacobian from its singular values.

    Parameters
    ----------
    singular_values : ndarray, shape (n,)
        Singular values σ_1 ≥ … ≥ σ_n > 0 of the (column-scaled) Jacobian.
    n_measurements : int
        Number of measurements (poses) m.

    Returns
    -------
    dict
        ``{"O1": …, "O5": …}`` as floats.

    Notes
    -----
    Alami Mchichi (2018), eqs 5.9–5.13::

        O1 = (σ_1 σ_2 … σ_n)^(1/n) / √m      (Borm & Menq 1989)
        O2 = σ_n / σ_1 = 1/κ                 (Driels & Pathre 1990)
        O3 = σ_n                             (Nahvi & Hollerbach 1996)
        O4 = σ_n² / σ_1                      (Nahvi & Hollerbach 1996)
        O5 = 1 / Σ_i 1/σ_i                   (Sun & Hollerbach 2008)

    O5 sums over the n unknowns; the source's eq. 8.8 sums to σ_m, a typo.

    References
    ----------
    Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes : configuration
    optimisée des artefacts et de la séquence de mesure de la méthode SAMBA en vue d'une
    estimation efficace des erreurs géométriques*. PhD thesis, École Polytechnique de
    Montréal, §5.4.

    Examples
    --------
    >>> o = observability_indices(np.array([4.0, 2.0, 1.0]), n_measurements=4)
    >>> round(o["O1"], 6), o["O2"], o["O3"], o["O4"], round(o["O5"], 6)
    (1.0, 0.25, 1.0, 0.25, 0.571429)
    """
    s = np.sort(np.asarray(singular_values, dtype=float))[::-1]
    return {
        "O1": float(np.exp(np.mean(np.log(s))) / np.sqrt(n_measurements)),
        "O2": float(s[-1] / s[0]),
        "O3": float(s[-1]),
        "O4": float(s[-1] ** 2 / s[0]),
        "O5": float(1.0 / np.sum(1.0 / s)),
    }


def _rref(a: np.ndarray, tol: float) -> np.ndarray:
    """Reduced row-echelon form with partial pivoting (rows = null vectors)."""
    m = a.copy()
    rows, cols = m.shape
    r = 0
    for c in range(cols):
        if r == rows:
            break
        p = r + int(np.argmax(np.abs(m[r:, c])))
        if abs(m[p, c]) <= tol:
            continue
        m[[r, p]] = m[[p, r]]
        m[r] /= m[r, c]
        for i in range(rows):
            if i != r:
                m[i] -= m[i, c] * m[r]
        r += 1
    return m[:r]


def analyse_identifiability(
    jacobian: np.ndarray,
    names: Sequence[str],
    *,
    rtol: float = 1e-8,
    n_measurements: int | None = None,
    report_names: Sequence[str] | None = None,
    share: float = 1e-3,
    svd: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> IdentifiabilityReport:
    """Rank, conditioning and null directions of an identification Jacobian.

    Parameters
    ----------
    jacobian : ndarray, shape (n_rows, n_unknowns)
        Sensitivities of the (weighted) residuals to the unknowns, evaluated at the
        nominal point.
    names : sequence of str
        Name of each unknown.
    rtol : float
        Rank tolerance relative to the largest singular value of the column-scaled
        Jacobian.
    n_measurements : int, optional
        Number of measurements (poses) m for O1 = (Π σ_i)^(1/n)/√m; rows/3 when omitted.
    report_names : sequence of str, optional
        If given, the message lists only the null directions touching these names
        (e.g. the machine parameters, not the ball coordinates).
    share : float
        Smallest |coefficient| (relative to the largest) kept in a null direction.
    svd : (column_norms, singular_values, vt), optional
        The SVD of the column-scaled Jacobian when the caller has it (the least-squares
        core does): it is not computed again.

    Returns
    -------
    IdentifiabilityReport
    """
    j = np.asarray(jacobian, dtype=float)
    names = tuple(names)
    if j.ndim != 2 or j.shape[1] != len(names):
        raise ValueError(f"jacobian must be (n_rows, {len(names)}), got {j.shape}")
    if not np.all(np.isfinite(j)):
        raise ValueError("jacobian holds NaN or infinite values")
    n = j.shape[1]
    if svd is None or svd[2].shape[0] < n:
        norms = np.linalg.norm(j, axis=0)
        norms = np.where(norms > 0, norms, 1.0)
        _, s, vt = np.linalg.svd(j / norms, full_matrices=True)
    else:
        norms, s, vt = svd
    s_full = np.zeros(n)
    s_full[: s.size] = s
    tol = rtol * (s_full[0] if s_full[0] > 0 else 1.0)
    rank = int(np.sum(s_full > tol))
    # J = U S Vᵀ D: the raw singular values are those of the n×n matrix S Vᵀ D
    s_raw = np.linalg.svd(s_full[: vt.shape[0], None] * vt * norms, compute_uv=False)
    if rank == n:
        cond_scaled = float(s_full[0] / s_full[-1])
        cond_raw = float(s_raw[0] / s_raw[-1]) if s_raw[-1] > 0 else float("inf")
    else:
        cond_scaled = cond_raw = float("inf")

    nulls: list[NullDirection] = []
    if rank < n:
        basis = vt[rank:]  # (k, n) rows span the null space
        for row in _rref(basis, 1e-9):
            v = row / np.linalg.norm(row)
            keep = np.abs(v) >= share * np.abs(v).max()
            # largest share first; ties (equal shares) in column order
            order = np.lexsort((np.arange(n), -np.round(np.abs(v), 9)))
            terms = tuple((names[i], float(v[i])) for i in order if keep[i])
            nulls.append(NullDirection(terms))

    observability: dict = {}
    if rank == n and n > 0:
        m = n_measurements if n_measurements is not None else max(j.shape[0] // 3, 1)
        observability = observability_indices(s_full, m)

    if rank == n:
        message = f"full rank: {n} unknowns, condition {cond_scaled:.4g} (columns scaled)"
    else:
        shown = nulls
        if report_names is not None:
            keep_names = set(report_names)
            shown = [d for d in nulls if keep_names & set(d.names)] or nulls
        message = f"rank {rank} of {n}: " + "; ".join(str(d) for d in shown)
    return IdentifiabilityReport(
        names=names,
        rank=rank,
        singular_values=s_full,
        singular_values_raw=s_raw,
        condition_raw=cond_raw,
        condition_scaled=cond_scaled,
        observability=observability,
        null_directions=tuple(nulls),
        column_norms=norms,
        tolerance=tol,
        message=message,
    )
