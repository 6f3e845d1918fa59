"""Coverage intervals and coverage regions from Monte Carlo samples (JCGM 101 §7.7, JCGM 102 §7.7).

All functions take a sample of model values, one row per trial: ``(M,)`` for a scalar
output or ``(M, m)`` for ``m`` outputs, in internal units.  They are pure functions of the
sample; :func:`mtmetrology.uncertainty.mcm.monte_carlo` calls them on every sequence and
on the whole run.

Besides the sample-based quantities, the module gives the normal-theory coverage factors
that the GUM uncertainty framework uses (``sqrt(χ²_m(p))`` for a hyper-ellipsoid, the
Bonferroni or independent-output factor for a hyper-rectangle) and the pairwise 2-D areas
of Sepahi Boroujeni (2021), Ch. 5 and 7, so that GUF and MCM regions are compared with one formula.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "Histogram",
    "PairwiseAreas",
    "SmallestRegion",
    "coverage_index",
    "coverage_intervals",
    "ellipse_area",
    "ellipsoidal_coverage_factor",
    "histogram",
    "intervals_and_histograms",
    "normal_ellipsoidal_coverage_factor",
    "normal_rectangular_coverage_factor",
    "pairwise_areas",
    "rectangle_area",
    "rectangular_coverage_factor",
    "shortest_interval",
    "smallest_region",
    "symmetric_interval",
]


def _check_probability(p: float) -> float:
    p = float(p)
    if not 0.0 < p < 1.0:
        raise ValueError(f"p must lie strictly between 0 and 1, got {p}")
    return p


def _as_sample(samples, name: str = "samples") -> tuple[np.ndarray, bool]:
    """Samples as an (M, m) float array, and whether the input was one-dimensional."""
    array = np.asarray(samples, dtype=float)
    vector = array.ndim == 1
    if vector:
        array = array[:, None]
    if array.ndim != 2:
        raise ValueError(f"{name} must have shape (M,) or (M, m), got {array.shape}")
    if array.shape[0] < 2:
        raise ValueError(f"{name} needs at least 2 trials, got {array.shape[0]}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return array, vector


def scatter(deviations: np.ndarray) -> np.ndarray:
    """Σ_k d_k d_kᵀ of an (M, m) array of deviations, shape (m, m).

    ``einsum`` streams the tall array once; ``deviations.T @ deviations`` goes through a
    BLAS call that is no faster for small m and, with a threaded BLAS on a busy machine,
    was measured 400x slower (20 ms against 0.05 ms for M = 10⁵, m = 1).
    """
    return np.einsum("ki,kj->ij", deviations, deviations)


def coverage_index(trials: int, p: float) -> int:
    """Number q of sorted values spanned by a 100p % coverage interval (JCGM 101:2008, 7.7.1).

    Parameters
    ----------
    trials : int
        Number of Monte Carlo trials M.
    p : float
        Coverage probability, 0 < p < 1.

    Returns
    -------
    int
        q = pM if pM is an integer, otherwise the integer part of pM + 1/2.

    Raises
    ------
    ValueError
        If p is outside (0, 1) or M is too small for q < M (at least one value outside).
    """
    p = _check_probability(p)
    pm = p * trials
    # pM is "an integer" up to binary rounding of p (0.95 * 10_000 = 9499.999...).
    q = round(pm) if abs(pm - round(pm)) < 1e-9 * max(1.0, pm) else math.floor(pm + 0.5)
    if q < 1 or q >= trials:
        raise ValueError(
            f"{trials} trials are too few for a {100 * p:g} % coverage interval: "
            f"need M > 1/(1 - p) = {1 / (1 - p):.0f} (JCGM 101 recommends M >= 100/(1 - p))"
        )
    return int(q)


def _region_index(trials: int, p: float) -> int:
    """Index ⌈pM⌉ of the sorted distance that bounds a 100p % sample region (JCGM 102, 7.7)."""
    p = _check_probability(p)
    pm = p * trials
    q = round(pm) if abs(pm - round(pm)) < 1e-9 * max(1.0, pm) else math.ceil(pm)
    if q < 1 or q > trials:
        raise ValueError(f"{trials} trials are too few for a {100 * p:g} % coverage region")
    return int(q)


def coverage_intervals(samples, p: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
    """Probabilistically symmetric and shortest 100p % coverage intervals, one sort.

    Parameters
    ----------
    samples : (M,) or (M, m) array
        Model values, one row per trial.
    p : float
        Coverage probability.

    Returns
    -------
    (symmetric, shortest) : two (2,) or (m, 2) arrays
        ``[low, high]`` for each output (shape (2,) for a one-dimensional sample).

    Raises
    ------
    ValueError
        For a malformed sample, p outside (0, 1), or too few trials for p.

    Notes
    -----
    With the values sorted, ỹ_(1) ≤ … ≤ ỹ_(M), and q from :func:`coverage_index`:

    - probabilistically symmetric (JCGM 101:2008, 7.7.2): r = (M − q)/2 if that is an
      integer, else (M − q + 1)/2, and the interval is [ỹ_(r), ỹ_(r+q)] (1-based);
    - shortest (JCGM 101:2008, 7.7.3): among [ỹ_(r), ỹ_(r+q)], r = 1, …, M − q, the one
      of least length. It never exceeds the symmetric interval, which is a candidate.
    """
    array, vector = _as_sample(samples)
    symmetric, shortest, _ = _intervals_and_histograms(array, p, bins=None)
    if vector:
        return symmetric[0], shortest[0]
    return symmetric, shortest


def intervals_and_histograms(samples, p: float = 0.95, bins: int = 100):
    """:func:`coverage_intervals` and the :func:`histogram` of every output, in one pass.

    Returns
    -------
    (symmetric (m, 2), shortest (m, 2), histograms tuple of m :class:`Histogram`)
        Identical to ``coverage_intervals(samples, p)`` and ``histogram(samples[:, j],
        bins)``; the binning that locates the tails gives the histogram for free.
    """
    array, _ = _as_sample(samples)
    return _intervals_and_histograms(array, p, int(bins))


def _intervals_and_histograms(array: np.ndarray, p: float, bins: int | None):
    trials, m = array.shape
    q = coverage_index(trials, p)
    r = (trials - q) // 2 if (trials - q) % 2 == 0 else (trials - q + 1) // 2
    tail = trials - q
    low_tail = np.empty((tail, m))  # ỹ_(1..M−q)
    high_tail = np.empty((tail, m))  # ỹ_(q+1..M)
    histograms = []
    for j in range(m):
        column = np.ascontiguousarray(array[:, j])
        low_tail[:, j], high_tail[:, j], counts, edges = _column_tails(column, tail, bins)
        if bins is not None:
            histograms.append(
                Histogram(values=counts / (trials * np.diff(edges)), edges=edges, density=True)
            )
    symmetric = np.stack([low_tail[r - 1], high_tail[r - 1]], axis=-1)  # (m, 2)
    lengths = high_tail - low_tail  # (M − q, m): length of [ỹ_(r), ỹ_(r+q)]
    start = np.argmin(lengths, axis=0)  # (m,), 0-based r − 1
    columns = np.arange(m)
    shortest = np.stack([low_tail[start, columns], high_tail[start, columns]], axis=-1)
    return symmetric, shortest, tuple(histograms)


#: Fine bins per display bin used to locate the tails (4100 fine bins for 100).
_FINE = 41


def _column_tails(values: np.ndarray, tail: int, bins: int | None):
    """Sorted ``tail`` smallest and largest values of a 1-D array, and its histogram.

    Every interval [ỹ_(r), ỹ_(r+q)] has its ends in these tails, so instead of sorting all
    M values the column is binned once (linear time): the exact bin counts say which bins
    hold the ``tail`` smallest (largest) values, one comparison keeps those bins, and only
    about (1 − p)M values are sorted.  The order statistics, hence the intervals, are
    identical to a full sort.  ``counts``/``edges`` are the ``bins``-bin histogram over
    [min, max] (None when ``bins`` is None); p < 1/2 (overlapping tails) sorts everything.
    """
    trials = values.size
    display = 100 if bins is None else bins
    low, high = float(values.min()), float(values.max())
    fine = display * _FINE
    if tail > trials - tail or not _resolvable(low, high, fine):
        ordered = np.sort(values)
        counts, edges = (None, None) if bins is None else _histogram(values, bins)
        return ordered[:tail], ordered[trials - tail :], counts, edges
    index = _bin_index(values, low, fine / (high - low), fine)
    fine_counts = np.bincount(index, minlength=fine)
    cumulative = np.cumsum(fine_counts)
    # Bins 0..b_low hold at least `tail` values; bins b_high..end as well.
    b_low = int(np.searchsorted(cumulative, tail))
    b_high = int(np.searchsorted(cumulative, trials - tail, side="right"))
    low_values = values[index <= b_low]
    high_values = values[index >= b_high]
    low_values = np.partition(low_values, tail - 1)[:tail]
    high_values = np.partition(high_values, high_values.size - tail)[high_values.size - tail :]
    counts = edges = None
    if bins is not None:
        counts = fine_counts.reshape(bins, _FINE).sum(axis=1)
        edges = np.linspace(low, high, bins + 1)
    return np.sort(low_values), np.sort(high_values), counts, edges


_ROUNDING_SHIFT = 1.5 * 2.0**52  # doubles in [2⁵², 2⁵³) are the integers
_ROUNDING_BITS = np.array(_ROUNDING_SHIFT).view(np.int64)


def _bin_index(values: np.ndarray, low: float, scale: float, bins: int) -> np.ndarray:
    """min(⌊(v − low)·scale⌋, bins − 1) as int64, for 0 ≤ (v − low)·scale ≤ bins.

    After ``floor``, adding 1.5·2⁵² is exact and gives a double whose bit pattern is the
    integer plus a constant, so the conversion is an in-place add and an integer subtract
    (several times faster than ``astype`` at M = 10⁶).  The index is monotone in v, which
    is what the tail selection relies on.
    """
    shifted = values - low
    shifted *= scale
    np.floor(shifted, out=shifted)
    shifted += _ROUNDING_SHIFT
    index = shifted.view(np.int64)
    index -= _ROUNDING_BITS
    np.minimum(index, bins - 1, out=index)  # v = max lands on bins; v >= low, so >= 0
    return index


def _resolvable(low: float, high: float, bins: int) -> bool:
    """Whether [low, high] splits into ``bins`` bins of positive width in floating point."""
    return high > low and bool(np.all(np.diff(np.linspace(low, high, bins + 1)) > 0))


def _histogram(values: np.ndarray, bins: int):
    """Counts and edges of ``bins`` equal bins over [min, max].

    A range too narrow to split (a constant, or a spread of a few ulps of a large value) is
    widened symmetrically to ``bins`` times 4 ulps, so every bin has a positive width.
    """
    low, high = float(values.min()), float(values.max())
    if not _resolvable(low, high, bins):
        centre = 0.5 * (low + high)
        half = max(bins * 4 * np.spacing(abs(centre)), 0.5 if centre == 0 else 0.0, high - low)
        low, high = centre - half, centre + half
    index = _bin_index(values, low, bins / (high - low), bins)
    return np.bincount(index, minlength=bins), np.linspace(low, high, bins + 1)


def symmetric_interval(samples, p: float = 0.95) -> np.ndarray:
    """Probabilistically symmetric 100p % coverage interval (JCGM 101:2008, 7.7.2).

    Shape (2,) for a (M,) sample, (m, 2) for a (M, m) sample; see
    :func:`coverage_intervals`.
    """
    return coverage_intervals(samples, p)[0]


def shortest_interval(samples, p: float = 0.95) -> np.ndarray:
    """Shortest 100p % coverage interval (JCGM 101:2008, 7.7.3).

    Shape (2,) for a (M,) sample, (m, 2) for a (M, m) sample; see
    :func:`coverage_intervals`.
    """
    return coverage_intervals(samples, p)[1]


def _moments(array: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    estimate = array.mean(axis=0)  # (m,)
    deviations = array - estimate  # (M, m)
    covariance = scatter(deviations) / (array.shape[0] - 1)  # (m, m)
    return estimate, covariance


def ellipsoidal_coverage_factor(
    samples, p: float = 0.95, *, estimate=None, covariance=None
) -> float:
    """Coverage factor k_p of the hyper-ellipsoidal 100p % region from a sample.

    Parameters
    ----------
    samples : (M,) or (M, m) array
        Model values, one row per trial.
    p : float
        Coverage probability.
    estimate : (m,) array, optional
        Centre y of the region; the sample mean by default.
    covariance : (m, m) array, optional
        U_y; the sample covariance by default.

    Returns
    -------
    float
        k_p such that a fraction p of the trials satisfy (y_r − y)ᵀ U_y⁻¹ (y_r − y) ≤ k_p².

    Raises
    ------
    ValueError
        For a malformed sample or p, or a covariance with a zero variance.

    Notes
    -----
    JCGM 102:2011, 7.7.2: d_r² = (y_r − y)ᵀ U_y⁻¹ (y_r − y) for every trial r, sorted;
    k_p = d_(q) with q = ⌈pM⌉. A singular U_y (outputs that are exact linear functions of
    each other) is handled with the pseudo-inverse, i.e. the region lives in the subspace
    the outputs span. For m = 1 it is the half-width, in units of u(y), of the shortest
    interval centred on y.
    """
    array, _ = _as_sample(samples)
    trials, _m = array.shape
    q = _region_index(trials, p)
    if estimate is None or covariance is None:
        mean, sample_covariance = _moments(array)
    centre = mean if estimate is None else np.asarray(estimate, dtype=float).reshape(-1)
    cov = sample_covariance if covariance is None else np.asarray(covariance, dtype=float)
    deviations = array - centre  # (M, m)
    scale = np.sqrt(np.diag(cov))  # (m,)
    if np.any(scale <= 0):
        raise ValueError("the covariance has a zero variance: no hyper-ellipsoidal region")
    # Work with the correlation matrix: its conditioning does not depend on the units.
    standardised = deviations / scale  # (M, m)
    correlation = cov / np.outer(scale, scale)  # (m, m)
    inverse = np.linalg.pinv(correlation, hermitian=True)  # (m, m)
    squared = np.einsum("ri,ij,rj->r", standardised, inverse, standardised)  # (M,)
    return float(np.sqrt(max(np.partition(squared, q - 1)[q - 1], 0.0)))


def rectangular_coverage_factor(
    samples, p: float = 0.95, *, estimate=None, standard_uncertainty=None
) -> float:
    """Coverage factor k_q of the hyper-rectangular 100p % region from a sample.

    Parameters
    ----------
    samples : (M,) or (M, m) array
        Model values, one row per trial.
    p : float
        Coverage probability.
    estimate : (m,) array, optional
        Centre y; the sample mean by default.
    standard_uncertainty : (m,) array, optional
        u(y_j); the sample standard deviations by default.

    Returns
    -------
    float
        k_q such that the box y_j ± k_q u(y_j) holds a fraction p of the trials.

    Raises
    ------
    ValueError
        For a malformed sample or p, or a zero standard uncertainty.

    Notes
    -----
    JCGM 102:2011, 7.7.3 (sample-based form): k_q is the ⌈pM⌉-th
    smallest of max_j |y_(j,r) − y_j| / u(y_j). For independent normal outputs it tends to
    Φ⁻¹((1 + p^(1/m))/2) (2.2365 for m = 2, p = 0.95).
    """
    array, _ = _as_sample(samples)
    trials = array.shape[0]
    q = _region_index(trials, p)
    centre = (
        array.mean(axis=0) if estimate is None else np.asarray(estimate, dtype=float).reshape(-1)
    )
    scale = (
        array.std(axis=0, ddof=1)
        if standard_uncertainty is None
        else np.asarray(standard_uncertainty, dtype=float).reshape(-1)
    )
    if np.any(scale <= 0):
        raise ValueError("a standard uncertainty is zero: no hyper-rectangular region")
    distance = np.max(np.abs(array - centre) / scale, axis=1)  # (M,)
    return float(np.partition(distance, q - 1)[q - 1])


def normal_ellipsoidal_coverage_factor(m: int, p: float = 0.95) -> float:
    """k_p = sqrt(χ²_m(p)) of the hyper-ellipsoid of an m-variate normal output: the
    ``coverage_factor`` of
    :func:`~mtmetrology.uncertainty.normal_coverage.normal_region_coverage` (JCGM 102:2011,
    6.5.2.3)."""
    from mtmetrology.uncertainty.normal_coverage import normal_region_coverage

    if int(m) < 1:
        raise ValueError(f"m must be a positive number of outputs, got {m}")
    return normal_region_coverage(int(m), p=p).coverage_factor


def normal_rectangular_coverage_factor(m: int, p: float = 0.95, *, independent: bool = False):
    """k_q of the hyper-rectangle of an m-variate normal output.

    Parameters
    ----------
    m : int
        Number of outputs.
    p : float
        Coverage probability.
    independent : bool
        True for independent outputs, Φ⁻¹((1 + p^(1/m))/2) (exact); False for the
        conservative Bonferroni factor Φ⁻¹(1 − (1 − p)/(2m)), valid for any correlation.

    Notes
    -----
    JCGM 102:2011, 6.5.4; the pairwise rectangles of Sepahi Boroujeni (2021), Ch. 5: 2.2365
    (independent) and 2.2414 (Bonferroni) for m = 2, p = 0.95.
    """
    from scipy import stats  # here, not at the top: importing it takes 0.5 s

    if int(m) < 1:
        raise ValueError(f"m must be a positive number of outputs, got {m}")
    p = _check_probability(p)
    if independent:
        return float(stats.norm.ppf((1.0 + p ** (1.0 / int(m))) / 2.0))
    return float(stats.norm.ppf(1.0 - (1.0 - p) / (2.0 * int(m))))


def ellipse_area(coverage_factor: float, u1: float, u2: float, correlation: float) -> float:
    """Area π k_p² u1 u2 sqrt(1 − ρ²) of a 2-D coverage ellipse (Sepahi Boroujeni 2021, Ch. 5)."""
    if not -1.0 <= correlation <= 1.0:
        raise ValueError(f"correlation must lie in [-1, 1], got {correlation}")
    return float(np.pi * coverage_factor**2 * u1 * u2 * np.sqrt(1.0 - correlation**2))


def rectangle_area(coverage_factor: float, u1: float, u2: float) -> float:
    """Area (2 k_q u1)(2 k_q u2) of a 2-D coverage rectangle (Sepahi Boroujeni 2021, Ch. 5)."""
    return float(4.0 * coverage_factor**2 * u1 * u2)


@dataclass(frozen=True)
class SmallestRegion:
    """Smallest coverage region approximated on a mesh of cells.

    Attributes
    ----------
    volume : float
        Volume (area for two outputs) of the region, in the product of the output units.
    probability : float
        Fraction of the trials inside the selected cells (≥ p by construction; the volume
        interpolates within the last cell to reach exactly p).
    edges : tuple of arrays
        Cell edges along each output.
    mask : bool array
        Selected cells, shape (bins,) * m.
    message : str
        What was computed.
    """

    volume: float
    probability: float
    edges: tuple[np.ndarray, ...]
    mask: np.ndarray
    message: str


def smallest_region(samples, p: float = 0.95, *, bins: int | None = None) -> SmallestRegion:
    """Smallest 100p % coverage region of a sample by a mesh of hyper-rectangular cells.

    Parameters
    ----------
    samples : (M, m) array
        Model values, one row per trial (m = 2 for the pairwise areas of Sepahi Boroujeni 2021).
    p : float
        Coverage probability.
    bins : int, optional
        Cells along each output. By default about (M/50)^(1/(m+2)) · 4, which keeps both
        the discretisation error and the count noise near the boundary at about 1 % for
        m = 2 and M = 10⁶.

    Returns
    -------
    SmallestRegion

    Raises
    ------
    ValueError
        For a malformed sample or p.

    Notes
    -----
    JCGM 102:2011, 7.7.4 (smallest coverage region); Sepahi Boroujeni (2021), Ch. 7: the
    output space is meshed into equal cells, cells are taken in order of decreasing count
    (highest density first) until their probability reaches p, and their volumes are
    summed. The last cell contributes the fraction of its volume needed to reach exactly p,
    which removes most of
    the discretisation bias. The mesh spans the central 1 − (1 − p)/10 of each marginal, so
    a few extreme trials do not stretch the cells; trials outside still count in M.
    """
    array, _ = _as_sample(samples)
    p = _check_probability(p)
    trials, m = array.shape
    if bins is None:
        bins = max(10, round(4 * (trials / 50.0) ** (1.0 / (m + 2))))
    if int(bins) < 2:
        raise ValueError(f"bins must be at least 2, got {bins}")
    tail = (1.0 - p) / 20.0
    limits = np.quantile(array, [tail, 1.0 - tail], axis=0)  # (2, m)
    if np.any(limits[1] <= limits[0]):
        raise ValueError("an output has (almost) no spread: the smallest region has no volume")
    counts, edges = np.histogramdd(array, bins=int(bins), range=list(zip(*limits, strict=True)))
    cell_volume = float(np.prod([e[1] - e[0] for e in edges]))
    flat = counts.ravel()
    order = np.argsort(flat, kind="stable")[::-1]  # highest density first
    cumulative = np.cumsum(flat[order]) / trials
    if cumulative[-1] < p:
        raise ValueError(f"the mesh holds only {cumulative[-1]:.4f} of the trials, less than p")
    last = int(np.searchsorted(cumulative, p))  # first index with cumulative >= p
    before = cumulative[last - 1] if last > 0 else 0.0
    fraction = (p - before) / (flat[order[last]] / trials)
    mask = np.zeros(flat.shape, dtype=bool)
    mask[order[: last + 1]] = True
    volume = (last + fraction) * cell_volume
    return SmallestRegion(
        volume=float(volume),
        probability=float(cumulative[last]),
        edges=tuple(edges),
        mask=mask.reshape(counts.shape),
        message=f"{last + 1} of {flat.size} cells ({bins} per output) hold {cumulative[last]:.4f}",
    )


@dataclass(frozen=True)
class PairwiseAreas:
    """2-D coverage areas of a pair of outputs (Sepahi Boroujeni 2021, Ch. 5 and 7), in
    output-unit products."""

    ellipse: float
    rectangle: float
    smallest: float
    coverage_factor: float
    rectangular_coverage_factor: float
    correlation: float
    standard_uncertainty: tuple[float, float]


def pairwise_areas(samples, i: int, j: int, p: float = 0.95, *, bins=None) -> PairwiseAreas:
    """Ellipse, rectangle and smallest-region areas of outputs i and j from a sample.

    Parameters
    ----------
    samples : (M, m) array
        Model values.
    i, j : int
        The two outputs.
    p : float
        Coverage probability.
    bins : int, optional
        Cells per output for :func:`smallest_region`.

    Notes
    -----
    Sepahi Boroujeni (2021), Ch. 5 and 7: A_e = π k_p² u1 u2 sqrt(1 − ρ²) with k_p from
    the 2-D sample (JCGM 102, 7.7.2), A_r = 4 k_q² u1 u2 with the sample k_q, and the
    smallest region by a cell mesh.
    """
    array, _ = _as_sample(samples)
    m = array.shape[1]
    if not (0 <= i < m and 0 <= j < m) or i == j:
        raise ValueError(f"i and j must be two different outputs in 0..{m - 1}, got {i}, {j}")
    pair = array[:, [i, j]]  # (M, 2)
    _, covariance = _moments(pair)
    u = np.sqrt(np.diag(covariance))
    rho = float(np.clip(covariance[0, 1] / (u[0] * u[1]), -1.0, 1.0))
    k_p = ellipsoidal_coverage_factor(pair, p)
    k_q = rectangular_coverage_factor(pair, p)
    return PairwiseAreas(
        ellipse=ellipse_area(k_p, u[0], u[1], rho),
        rectangle=rectangle_area(k_q, u[0], u[1]),
        smallest=smallest_region(pair, p, bins=bins).volume,
        coverage_factor=k_p,
        rectangular_coverage_factor=k_q,
        correlation=rho,
        standard_uncertainty=(float(u[0]), float(u[1])),
    )


@dataclass(frozen=True)
class Histogram:
    """Histogram of one output: ``values`` per bin (a density if ``density``), bin ``edges``."""

    values: np.ndarray
    edges: np.ndarray
    density: bool

    @property
    def centres(self) -> np.ndarray:
        """Bin centres, shape (bins,)."""
        return 0.5 * (self.edges[1:] + self.edges[:-1])


def histogram(samples, bins: int | str = 100, *, density: bool = True) -> Histogram:
    """Histogram of a one-dimensional sample (an approximation of the output PDF).

    Parameters
    ----------
    samples : (M,) array
        Values of one output.
    bins : int or str
        Number of bins or a numpy bin rule ("auto", "fd", ...).
    density : bool
        Normalise to a probability density (JCGM 101, 7.5.1) rather than counts.
    """
    array = np.asarray(samples, dtype=float)
    if array.ndim != 1:
        raise ValueError(f"histogram needs a one-dimensional sample, got shape {array.shape}")
    if isinstance(bins, str) or not np.all(np.isfinite(array)):
        values, edges = np.histogram(array, bins=bins, density=density)
        return Histogram(values=values, edges=edges, density=density)
    bins = int(bins)
    if bins < 1:
        raise ValueError(f"bins must be a positive integer, got {bins}")
    # One pass for the bin index and one bincount, instead of np.histogram's blocked
    # search with edge corrections (4x slower at M = 10⁶); a value on an inner edge may
    # land in the neighbouring bin after rounding, which a density estimate tolerates.
    counts, edges = _histogram(array, bins)
    if density:
        return Histogram(values=counts / (array.size * np.diff(edges)), edges=edges, density=True)
    return Histogram(values=counts, edges=edges, density=False)
