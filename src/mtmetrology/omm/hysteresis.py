"""Probing and axis hysteresis errors from replicated ring-gauge probing (eqs. 4-3, 4-4).

At each indexation ψ of a ring gauge, the radial projection r is recorded n times under
two conditions: with hysteresis involved (the previous touch was on the opposite wall)
and without it (the previous touch was the same point), or, for an axis, after a
pre-movement along the + and along the − direction of the cross axis. The hysteresis
error is the difference of the two means, with the standard deviations of the means
combined in quadrature. :func:`hysteresis_errors` returns a :class:`HysteresisResult`.

References
----------
Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with On-Machine
Tool Metrology*. PhD thesis, Polytechnique Montréal, §4 (eqs. 4-3, 4-4; Figs. 4-16,
4-17) and App. A (eq. A.4-4).

JCGM 100:2008, *Evaluation of measurement data — Guide to the expression of uncertainty
in measurement*, 4.2 (type A evaluation) and G.4 (Welch–Satterthwaite).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mtmetrology.errors import InputError
from mtmetrology.formatting import format_uncertainty, format_value
from mtmetrology.omm.notebook import OMMNotebookRepr
from mtmetrology.uncertainty.guf import welch_satterthwaite
from mtmetrology.uncertainty.outputs import Output
from mtmetrology.units import from_internal

__all__ = [
    "HYSTERESIS_KINDS",
    "HysteresisResult",
    "hysteresis_errors",
    "radial_projection",
    "summary_line",
]

#: The two tests and the labels of (affected, reference) condition in each.
HYSTERESIS_KINDS = {"probing": ("hysteresis", "direct"), "axis": ("+", "-")}


def radial_projection(x, y, psi) -> np.ndarray:
    """Radial projection of ring-gauge readings (Sepahi Boroujeni (2021), eq. A.4-4).

    Parameters
    ----------
    x, y : (m,) array_like, mm
        Readings relative to the ring centre.
    psi : (m,) array_like, rad
        Indexation of each reading (direction of the nominal normal N̂ = (cos ψ, sin ψ)).

    Returns
    -------
    (m,) ndarray, mm
        R = (X, Y) · N̂.

    Examples
    --------
    >>> float(radial_projection(0.0, 28.78, np.pi / 2))
    28.78
    """
    psi = np.asarray(psi, float)
    return np.asarray(x, float) * np.cos(psi) + np.asarray(y, float) * np.sin(psi)


@dataclass(frozen=True)
class HysteresisResult(OMMNotebookRepr):
    """Hysteresis errors per indexation and their summary (lengths in mm, angles in rad).

    Attributes
    ----------
    kind : {"probing", "axis"}
        "probing": H = r̄_H − r̄ (with minus without hysteresis); "axis": H = r̄(+) − r̄(−)
        (pre-movement along + minus along − the cross axis).
    psi : (m,) ndarray, rad
        Indexations, ascending.
    mean_affected, mean_reference : (m,) ndarray, mm
        r̄_H (or r̄(+)) and r̄ (or r̄(−)).
    std_affected, std_reference : (m,) ndarray, mm
        Sample standard deviations s of the replicates (ddof = 1).
    n_affected, n_reference : (m,) ndarray of int
        Replicates of each condition.
    hysteresis : (m,) ndarray, mm
        H_ψ (eq. 4-3).
    standard_uncertainty : (m,) ndarray, mm
        u(H_ψ) (eq. 4-4).
    dof : (m,) ndarray
        Welch–Satterthwaite effective degrees of freedom of u(H_ψ).
    coverage_factor : (m,) ndarray
        k = t quantile at probability ``p`` with ``dof`` degrees of freedom.
    p : float
        Coverage probability of the intervals H_ψ ± k u(H_ψ).
    mean, mean_u : float, mm
        H̄ = Σ H_ψ / m and u(H̄) = √(Σ u²(H_ψ)) / m (indexations independent).
    mean_abs : float, mm
        Σ |H_ψ| / m (descriptive: the magnitude of the hysteresis whatever its sign).
    rms_u : float, mm
        √(Σ u²(H_ψ) / m): the typical u(H_ψ) of one indexation.
    source : str or None
        The records file, recorded as ``source`` in the document.
    """

    kind: str
    psi: np.ndarray
    mean_affected: np.ndarray
    mean_reference: np.ndarray
    std_affected: np.ndarray
    std_reference: np.ndarray
    n_affected: np.ndarray
    n_reference: np.ndarray
    hysteresis: np.ndarray
    standard_uncertainty: np.ndarray
    dof: np.ndarray
    coverage_factor: np.ndarray
    p: float
    mean: float
    mean_u: float
    mean_abs: float
    rms_u: float
    source: str | None = None

    def __len__(self) -> int:
        return self.psi.size

    def outputs(self) -> tuple[Output, ...]:
        """One :class:`~mtmetrology.uncertainty.Output` per indexation, ``H_<ψ in deg>``, µm."""
        out = []
        for j in range(len(self)):
            h, u, k = (
                from_internal(self.hysteresis[j], "µm"),
                from_internal(self.standard_uncertainty[j], "µm"),
                float(self.coverage_factor[j]),
            )
            big_u = k * u
            out.append(
                Output(
                    name=f"H_{_deg(self.psi[j]):g}",
                    value=float(h),
                    unit="µm",
                    u=float(u),
                    U=float(big_u),
                    k=k,
                    p=self.p,
                    interval=(float(h - big_u), float(h + big_u)),
                )
            )
        return tuple(out)

    def to_dict(self) -> dict:
        """The ``hysteresis-result`` JSON document (deg, mm, µm)."""
        affected, reference = HYSTERESIS_KINDS[self.kind]
        doc = {
            "kind": "hysteresis-result",
            "version": 1,
            "test": self.kind,
            "method": "Sepahi Boroujeni (2021), eqs. 4-3 and 4-4; Welch–Satterthwaite ν_eff",
            "definition": f"H = mean r ({affected}) - mean r ({reference})",
            "outputs": [o.to_dict() for o in self.outputs()],
            "indexations": [
                {
                    "psi": _deg(self.psi[j]),
                    f"mean_r_{affected}": float(self.mean_affected[j]),
                    f"mean_r_{reference}": float(self.mean_reference[j]),
                    f"s_{affected}": _um(self.std_affected[j]),
                    f"s_{reference}": _um(self.std_reference[j]),
                    f"n_{affected}": int(self.n_affected[j]),
                    f"n_{reference}": int(self.n_reference[j]),
                    "dof": float(self.dof[j]),
                }
                for j in range(len(self))
            ],
            "units": {"psi": "deg", "mean_r": "mm", "s": "µm", "H": "µm"},
            "summary": {
                "mean": _um(self.mean),
                "mean_u": _um(self.mean_u),
                "mean_abs": _um(self.mean_abs),
                "rms_u": _um(self.rms_u),
                "unit": "µm",
            },
        }
        if self.source is not None:
            doc["source"] = self.source
        return doc


def _deg(angle) -> float:
    # ψ is a label read in degrees: undo the rad round trip (30 → 29.999999999999996).
    return round(float(from_internal(angle, "deg")), 9)


def _um(value) -> float:
    return float(from_internal(value, "µm"))


def hysteresis_errors(
    psi,
    radius,
    affected,
    *,
    kind: str = "probing",
    p: float = 0.95,
    where: str = "records",
) -> HysteresisResult:
    """Hysteresis error H_ψ and u(H_ψ) at each indexation (Sepahi Boroujeni (2021), 4-3, 4-4).

    Parameters
    ----------
    psi : (m,) array_like, rad
        Indexation of each reading; readings with equal ψ belong to one indexation.
    radius : (m,) array_like, mm
        Radial projection of each reading (:func:`radial_projection`).
    affected : (m,) array_like of bool
        True for the readings with hysteresis involved (probing test) or after the +
        pre-movement (axis test); False for the reference condition.
    kind : {"probing", "axis"}
        Which test the readings come from (labels of the result only).
    p : float, default 0.95
        Coverage probability of the intervals.
    where : str
        Name of the source for error messages.

    Returns
    -------
    HysteresisResult

    Raises
    ------
    InputError
        Fewer than 2 replicates of a condition at an indexation, non-finite values,
        mismatched lengths, an unknown ``kind`` or ``p`` outside (0, 1).

    Notes
    -----
    Sepahi Boroujeni (2021), eqs. 4-3 and 4-4::

        H_ψ    = r̄_{H,ψ} − r̄_ψ
        u(H_ψ) = √(u²(r̄_{H,ψ}) + u²(r̄_ψ)),   u(r̄) = s / √n

    (type A evaluations, JCGM 100:2008, 4.2.3, of two independent means). The axis
    hysteresis is H = r̄(+ pre-move) − r̄(− pre-move) with the same uncertainty. The
    coverage factor is the t quantile with the Welch–Satterthwaite ν_eff (JCGM
    100:2008, G.4.1; not truncated), ν_eff = u⁴ / (u_H⁴/(n_H − 1) + u_r⁴/(n_r − 1)).

    The thesis's worked example (ψ = 60°: r̄_H = 28.7821 mm, r̄ = 28.7819 mm) reports
    H₆₀ = −0.17 µm, whereas eq. 4-3 on the printed means gives +0.2 µm; this function
    implements eq. 4-3 as written.

    References
    ----------
    Sepahi Boroujeni, S. (2021). *Uncertainty of Form and Size Measurement with
    On-Machine Tool Metrology*. PhD thesis, Polytechnique Montréal, §4.

    JCGM 100:2008, *Evaluation of measurement data — Guide to the expression of
    uncertainty in measurement*, 4.2 and G.4.

    Examples
    --------
    Replicates 1, 2, 3 µm with hysteresis and 2, 4, 6, 8 µm without: H = −3 µm and
    u(H) = √(1/3 + (20/3)/4) = √2 µm:

    >>> from mtmetrology.units import to_internal
    >>> r = to_internal(np.array([1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 8.0]), "µm")
    >>> res = hysteresis_errors(np.zeros(7), r, [True] * 3 + [False] * 4)
    >>> h = from_internal(res.hysteresis[0], "µm")
    >>> u = from_internal(res.standard_uncertainty[0], "µm")
    >>> round(float(h), 9), round(float(u) ** 2, 9)
    (-3.0, 2.0)
    """
    from scipy import stats  # here, not at the top: importing it takes 0.5 s

    if kind not in HYSTERESIS_KINDS:
        raise InputError(f"kind: must be one of {sorted(HYSTERESIS_KINDS)}, got {kind!r}")
    if not (0.0 < p < 1.0):
        raise InputError(f"p: the coverage probability must be in (0, 1), got {p}")
    psi = np.asarray(psi, float)
    r = np.asarray(radius, float)
    hit = np.asarray(affected, bool)
    if not (psi.ndim == 1 and psi.shape == r.shape == hit.shape):
        raise InputError(f"{where}: psi, radius and condition must be 1-D of one length")
    if not (np.all(np.isfinite(psi)) and np.all(np.isfinite(r))):
        raise InputError(f"{where}: psi and radius must be finite")
    labels = HYSTERESIS_KINDS[kind]
    angles, group = np.unique(psi, return_inverse=True)
    rows = []
    for g, angle in enumerate(angles):
        sides = []
        for flag, label in zip((True, False), labels, strict=True):
            x = r[(group == g) & (hit == flag)]
            if x.size < 2:
                raise InputError(
                    f"{where}: psi = {from_internal(angle, 'deg'):g} deg has {x.size} "
                    f"'{label}' reading(s); a standard deviation of the mean needs at least 2"
                )
            sides.append((x.mean(), x.std(ddof=1), x.size))
        (m_a, s_a, n_a), (m_r, s_r, n_r) = sides
        u2 = np.array([s_a**2 / n_a, s_r**2 / n_r])  # u²(r̄) = s²/n, eq. 4-4
        nu = welch_satterthwaite([1.0, -1.0], np.diag(u2), [n_a - 1, n_r - 1])
        rows.append((m_a, m_r, s_a, s_r, n_a, n_r, m_a - m_r, math.sqrt(u2.sum()), nu))
    c = [np.array(col) for col in zip(*rows, strict=True)]
    h, u, nu = c[6], c[7], c[8]
    q = 0.5 * (1.0 + p)
    finite = np.isfinite(nu)
    k = np.where(finite, stats.t.ppf(q, np.where(finite, nu, 1.0)), stats.norm.ppf(q))
    m = h.size
    return HysteresisResult(
        kind=kind,
        psi=angles,
        mean_affected=c[0],
        mean_reference=c[1],
        std_affected=c[2],
        std_reference=c[3],
        n_affected=c[4].astype(int),
        n_reference=c[5].astype(int),
        hysteresis=h,
        standard_uncertainty=u,
        dof=nu,
        coverage_factor=k,
        p=float(p),
        mean=float(h.mean()),
        mean_u=float(np.sqrt(np.sum(u**2)) / m),
        mean_abs=float(np.abs(h).mean()),
        rms_u=float(np.sqrt(np.mean(u**2))),
    )


def summary_line(summary: dict) -> str:
    """The document's summary in words: mean H with its u, mean |H|, RMS u(H) (GUM 7.2.6).

    Parameters
    ----------
    summary : dict
        The ``summary`` block of a ``hysteresis-result`` document (µm).

    Returns
    -------
    str
        What the console and the report print.
    """
    mean_u = summary["mean_u"]
    return (
        f"mean H = {format_value(summary['mean'], mean_u)} µm "
        f"(u = {format_uncertainty(mean_u)} µm), "
        f"mean |H| = {format_value(summary['mean_abs'], mean_u)} µm, "
        f"RMS u(H) = {format_uncertainty(summary['rms_u'])} µm"
    )
