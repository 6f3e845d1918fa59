"""ISO 230-2 positioning parameters of linear axes, vectorised over many axis tests.

The deviations of one test form an array ``x[i, j, d]`` (target i = 1 … m, run j = 1 … n,
approach d: 0 = ↑ positive, 1 = ↓ negative), ``x_ij = P_ij − P_i`` (actual minus target
position; ISO 230-2:2014, clause 3).  Many tests stack in front: ``(tests, m, n, 2)``.  Every
statistic is a reduction over the run axis and then over the target axis, so 10⁴ tests are
analysed in a handful of numpy passes.

Definitions (ISO 230-2:2014, clause 3; the 2006 and 1997 editions define the same
quantities with the same formulas, reproduced below):

- mean unidirectional positional deviation ``x̄_i↑ = (1/n) Σ_j x_ij↑``;
- mean bidirectional positional deviation ``x̄_i = (x̄_i↑ + x̄_i↓)/2``;
- reversal value ``B_i = x̄_i↑ − x̄_i↓``; axis ``B = max |B_i|``; mean
  ``B̄ = (1/m) Σ_i B_i``;
- estimator of the unidirectional standard uncertainty of positioning
  ``s_i↑ = sqrt((1/(n − 1)) Σ_j (x_ij↑ − x̄_i↑)²)``;
- unidirectional repeatability ``R_i↑ = 4 s_i↑``, bidirectional
  ``R_i = max[2 s_i↑ + 2 s_i↓ + |B_i|; R_i↑; R_i↓]``, axis ``R↑ = max R_i↑``,
  ``R = max R_i``;
- unidirectional systematic positioning error ``E↑ = max x̄_i↑ − min x̄_i↑``,
  bidirectional ``E = max[x̄_i↑; x̄_i↓] − min[x̄_i↑; x̄_i↓]``;
- range of the mean bidirectional positional deviation ``M = max x̄_i − min x̄_i``;
- unidirectional accuracy ``A↑ = max[x̄_i↑ + 2 s_i↑] − min[x̄_i↑ − 2 s_i↑]``,
  bidirectional ``A = max[x̄_i↑ + 2 s_i↑; x̄_i↓ + 2 s_i↓] − min[x̄_i↑ − 2 s_i↑; x̄_i↓ − 2 s_i↓]``
 .

The first edition (1988) used bands of ±3 standard deviations where the later ones use
±2 standard uncertainties ("instead of using 3 standard deviations (old standard), 2
standard uncertainties are used", AMT, *ISO 230-2 revised*, amtonline.org article 133530):
with ``k = 3`` for 1988 and ``k = 2`` otherwise, ``R_i↑ = 2k s_i↑``,
``R_i = max[k s_i↑ + k s_i↓ + |B_i|; R_i↑; R_i↓]`` and the A bands ``x̄ ± k s``
(:data:`BAND`; the 1988 repeatability as 6 s follows from the ±3 s band by the same
construction, the 1988 text itself was not available).

The editions are named options (:data:`EDITIONS`).  The public abstracts of the 2006 and
2014 editions differ by the 2014 annexes on periodic positioning error and on ball arrays
and step gauges; no difference between their definitions of A and R could be cited from a
public source, so those two editions compute the same numbers here (the module tests pin
it, and the 1988/2014 difference).

VDI/DGQ 3441 (1977), the German guideline CARTO also offers, states the axis by four
numbers computed from the same per-target statistics, with a pooled scatter
``s_i = sqrt((s_i↑² + s_i↓²)/2)`` and the ±3 s band:

- position scatter ``P_s,i = 6 s_i``, ``P_s = max P_s,i``;
- reversal span ``U_i = |x̄_i↑ − x̄_i↓|``, ``U = max U_i``, ``Ū = (1/m) Σ U_i``;
- position deviation ``P_a = max x̄_i − min x̄_i``;
- position uncertainty ``P = max[x̄_i + (U_i + P_s,i)/2] − min[x̄_i − (U_i + P_s,i)/2]``.

The pooled form of s_i is this implementation's reading (the guideline text itself was not
available); it is stated so that a reader can check it.
"""

from __future__ import annotations

import numpy as np

from mtmetrology.errors import InputError

__all__ = ["BAND", "EDITIONS", "MIN_RUNS", "PER_TARGET", "SCALARS", "evaluate"]

#: Editions offered: name -> the ISO 230-2 edition (or guideline) whose definitions apply.
EDITIONS = {
    "2014": "ISO 230-2:2014",
    "2006": "ISO 230-2:2006",
    "1997": "ISO 230-2:1997",
    "1988": "ISO 230-2:1988",
    "vdi3441": "VDI/DGQ 3441:1977",
}
#: Multiple of s in the bands of A and R: 2 from the 1997 edition on, 3 in the first (1988).
BAND = {"2014": 2.0, "2006": 2.0, "1997": 2.0, "1988": 3.0}
#: Runs per direction the standard requires at least (ISO 230-2: five at each target in
#: each direction).
MIN_RUNS = 5
#: Per-target statistics of the ISO editions (arrays (..., m)).
PER_TARGET = ("mean_up", "mean_down", "mean", "s_up", "s_down", "B_i", "R_i_up", "R_i_down", "R_i")
#: Axis parameters of the ISO editions (arrays (...)).
SCALARS = ("B", "B_mean", "R_up", "R_down", "R", "E_up", "E_down", "E", "M", "A_up", "A_down", "A")
_VDI_TARGET = ("mean_up", "mean_down", "mean", "s_i", "Ps_i", "U_i")
_VDI_SCALARS = ("Ps", "U", "U_mean", "Pa", "P")


def _range(high: np.ndarray, low: np.ndarray) -> np.ndarray:
    """max over targets of ``high`` minus min over targets of ``low`` (last axis)."""
    return high.max(axis=-1) - low.min(axis=-1)


def evaluate(x: np.ndarray, edition: str = "2014") -> dict[str, np.ndarray]:
    """The positioning parameters of one or many axis tests.

    Parameters
    ----------
    x : ndarray, shape (..., m, n, 2)
        Positional deviations ``x_ij = P_ij − P_i`` (any one length unit; the parameters
        come out in it): m targets, n runs, approach ↑ (index 0) and ↓ (index 1).
    edition : {"2014", "2006", "1997", "1988", "vdi3441"}

    Returns
    -------
    dict of str to ndarray
        The ISO editions: :data:`PER_TARGET` (shape (..., m)) and :data:`SCALARS` (shape
        (...)); VDI/DGQ 3441: ``mean_up``, ``mean_down``, ``mean``, ``s_i``, ``Ps_i``,
        ``U_i`` and ``Ps``, ``U``, ``U_mean``, ``Pa``, ``P`` (module notes).

    Raises
    ------
    InputError
        An unknown edition, a shape that is not (..., m, n, 2), fewer than 2 targets or
        :data:`MIN_RUNS` runs, a value that is not finite.
    """
    if edition not in EDITIONS:
        raise InputError(f"edition: {edition!r} is not one of {', '.join(EDITIONS)}")
    x = np.asarray(x, dtype=float)
    if x.ndim < 3 or x.shape[-1] != 2:
        raise InputError(f"deviations: shape {x.shape} is not (..., targets, runs, 2)")
    if x.shape[-3] < 2:
        raise InputError(f"deviations: {x.shape[-3]} target(s); an axis test needs 2 at least")
    if x.shape[-2] < MIN_RUNS:
        raise InputError(
            f"deviations: {x.shape[-2]} runs per direction; ISO 230-2 requires {MIN_RUNS} at least"
        )
    if not np.all(np.isfinite(x)):
        raise InputError("deviations: a value is not finite")
    means = x.mean(axis=-2)  # (..., m, 2)
    dev = x - means[..., None, :]  # two passes (not sums of squares): exact for large means
    s = np.sqrt(np.einsum("...jd,...jd->...d", dev, dev) / (x.shape[-2] - 1))
    up, down = means[..., 0], means[..., 1]
    s_up, s_down = s[..., 0], s[..., 1]
    mean = 0.5 * (up + down)
    if edition == "vdi3441":
        s_i = np.sqrt(0.5 * (s_up**2 + s_down**2))
        ps_i = 6.0 * s_i
        u_i = np.abs(up - down)
        half = 0.5 * (u_i + ps_i)
        out = dict(zip(_VDI_TARGET, (up, down, mean, s_i, ps_i, u_i), strict=True))
        out |= {
            "Ps": ps_i.max(axis=-1),
            "U": u_i.max(axis=-1),
            "U_mean": u_i.mean(axis=-1),
            "Pa": _range(mean, mean),
            "P": _range(mean + half, mean - half),
        }
        return out
    b_i = up - down
    k = BAND[edition]
    r_up, r_down = 2.0 * k * s_up, 2.0 * k * s_down
    r_i = np.maximum(k * s_up + k * s_down + np.abs(b_i), np.maximum(r_up, r_down))
    hi_up, lo_up = up + k * s_up, up - k * s_up
    hi_down, lo_down = down + k * s_down, down - k * s_down
    out = dict(zip(PER_TARGET, (up, down, mean, s_up, s_down, b_i, r_up, r_down, r_i), strict=True))
    out |= {
        "B": np.abs(b_i).max(axis=-1),
        "B_mean": b_i.mean(axis=-1),
        "R_up": r_up.max(axis=-1),
        "R_down": r_down.max(axis=-1),
        "R": r_i.max(axis=-1),
        "E_up": _range(up, up),
        "E_down": _range(down, down),
        "E": _range(np.maximum(up, down), np.minimum(up, down)),
        "M": _range(mean, mean),
        "A_up": _range(hi_up, lo_up),
        "A_down": _range(hi_down, lo_down),
        "A": _range(np.maximum(hi_up, hi_down), np.minimum(lo_up, lo_down)),
    }
    return out
