"""Figures of a result and its uncertainty: parameter tables, correlation heat maps, the
Monte Carlo histogram against the GUF law, coverage ellipses, uncertainty budgets and the
ISO 14253-1 conformity zones.

References
----------
JCGM 100:2008 (budgets, 7.2.6 rounding); JCGM 101:2008, 9 (histogram against the GUF
PDF); JCGM 102:2011, 7.7 (coverage regions); ISO 14253-1:2017 (conformance and
nonconformance zones).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure

from mtmetrology.formatting import format_signed, format_uncertainty, format_value
from mtmetrology.report.figures.style import (
    BLUE,
    GREEN,
    GREY,
    ORANGE,
    RED,
    axis_label,
    legend_below,
    new_figure,
    plain_ticks,
)
from mtmetrology.units import convert, display_unit

__all__ = [
    "budget_bars",
    "conformity_zones",
    "correlation_heatmap",
    "coverage_ellipses",
    "histogram_vs_normal",
    "parameter_table_columns",
    "parameter_table_rows",
]


def parameter_table_columns(coverage_factor: float = 2.0) -> list[str]:
    """Column headings matching :func:`parameter_table_rows`."""
    return ["parameter", "value", "unit", "u", f"U (k = {coverage_factor:.3g})"]


def parameter_table_rows(parameter_set, *, coverage_factor: float = 2.0) -> list[list[str]]:
    """Rows ``name, value, unit, u, U`` of a parameter set, in its customary units.

    Parameters
    ----------
    parameter_set : ParameterSet or dict
        A :class:`mtmetrology.kinematics.parameter_set.ParameterSet`, or its document
        (``parameters: [{name, value, unit, u}]``).
    coverage_factor : float
        k of the expanded uncertainty ``U = k u``.

    Returns
    -------
    list of [str, str, str, str, str]
        The value rounded to the second significant digit of u (JCGM 100:2008, 7.2.6),
        u and U with two significant digits; a dash where no u is known.

    Examples
    --------
    >>> doc = {"parameters": [{"name": "E_X0C", "value": -104.5912, "unit": "µm", "u": 0.734}]}
    >>> parameter_table_rows(doc)
    [['E_X0C', '-104.59', 'µm', '0.73', '1.5']]
    """
    document = parameter_set if isinstance(parameter_set, dict) else parameter_set.to_document()
    rows = []
    for p in document["parameters"]:
        u = p.get("u")
        rows.append(
            [
                p["name"],
                format_value(p["value"], u),
                p["unit"],
                format_uncertainty(u),
                format_uncertainty(None if u is None else coverage_factor * u),
            ]
        )
    return rows


def correlation_heatmap(names: Sequence[str], correlation, *, title: str | None = None) -> Figure:
    """Heat map of a correlation matrix, −1 (blue) to +1 (red), values printed when few.

    Parameters
    ----------
    names : sequence of str, length n
    correlation : (n, n) array_like
        Correlation coefficients.

    Examples
    --------
    >>> fig = correlation_heatmap(["E_X0C", "E_X0S"], [[1.0, -0.9], [-0.9, 1.0]])
    >>> len(fig.axes)  # the map and its colour bar
    2
    """
    r = np.asarray(correlation, dtype=float)
    n = len(names)
    if r.shape != (n, n):
        raise ValueError(f"correlation must be {n} x {n} for {n} names, got {r.shape}")
    size = min(9.0, 2.5 + 0.42 * n)
    fig = new_figure(size + 1.2, size)
    ax = fig.add_subplot()
    image = ax.imshow(r, cmap="RdBu_r", vmin=-1.0, vmax=1.0)
    ax.set_xticks(range(n), names, rotation=90, fontsize=8)
    ax.set_yticks(range(n), names, fontsize=8)
    if n <= 16:
        for i in range(n):
            for j in range(n):
                colour = "white" if abs(r[i, j]) > 0.6 else "black"
                ax.text(
                    j, i, format_signed(r[i, j]), ha="center", va="center", fontsize=7, color=colour
                )
    fig.colorbar(image, ax=ax, shrink=0.8, label="correlation coefficient")
    ax.set_title(title or "Correlation of the estimates")
    return plain_ticks(fig)


def histogram_vs_normal(
    samples,
    mean: float,
    u: float,
    name: str,
    unit: str = "",
    *,
    dof: float | None = None,
    interval: Sequence[float] | None = None,
    guf_interval: Sequence[float] | None = None,
    bins: int = 100,
) -> Figure:
    """Monte Carlo histogram of one output against the GUF distribution (JCGM 101, 9).

    Parameters
    ----------
    samples : (M,) array_like or histogram
        Model values of the output, or a histogram with ``values`` (densities) and
        ``edges`` (:class:`mtmetrology.uncertainty.regions.Histogram`).
    mean, u : float
        GUF estimate and standard uncertainty (same unit as the samples).
    name, unit : str
    dof : float, optional
        Effective degrees of freedom: a scaled and shifted t distribution is drawn
        instead of the normal (JCGM 100:2008, G.6.2) when finite.
    interval, guf_interval : (low, high), optional
        Monte Carlo and GUF coverage intervals, drawn as vertical lines.

    Examples
    --------
    >>> rng = __import__("numpy").random.default_rng(1)
    >>> fig = histogram_vs_normal(rng.normal(10.0, 0.5, 1000), 10.0, 0.5, "l", "µm")
    >>> fig.axes[0].get_xlabel()
    'l (µm)'
    """
    from scipy import stats

    if hasattr(samples, "edges") and hasattr(samples, "values"):
        edges = np.asarray(samples.edges, dtype=float)
        density = np.asarray(samples.values, dtype=float)
    else:
        values = np.asarray(samples, dtype=float).ravel()
        if values.size < 2:
            raise ValueError("a histogram needs at least two samples")
        density, edges = np.histogram(values, bins=bins, density=True)
    fig = new_figure()
    ax = fig.add_subplot()
    ax.stairs(density, edges, fill=True, color=BLUE, alpha=0.45, label="Monte Carlo")
    x = np.linspace(min(edges[0], mean - 4 * u), max(edges[-1], mean + 4 * u), 400)
    if dof is not None and np.isfinite(dof):
        pdf, law = stats.t.pdf((x - mean) / u, dof) / u, f"GUF: t, ν = {dof:.3g}"
    else:
        pdf, law = stats.norm.pdf(x, mean, u), "GUF: normal"
    ax.plot(x, pdf, color=ORANGE, lw=2, label=law)
    for bounds, colour, label in (
        (interval, BLUE, "Monte Carlo interval"),
        (guf_interval, ORANGE, "GUF interval"),
    ):
        if bounds is not None:
            for k, b in enumerate(bounds):
                ax.axvline(b, color=colour, ls="--", lw=1, label=label if k == 0 else None)
    ax.set_xlabel(axis_label(name, unit))
    ax.set_ylabel("probability density")
    ax.set_title(f"Distribution of {name}")
    legend_below(fig, ax)
    return plain_ticks(fig)


def _ellipse(centre, cov2, k: float, n: int = 181) -> np.ndarray:
    """Points of {x : (x − c)ᵀ Σ⁻¹ (x − c) = k²} for a 2 x 2 covariance Σ."""
    w, v = np.linalg.eigh(cov2)
    t = np.linspace(0.0, 2.0 * np.pi, n)
    circle = np.stack([np.cos(t), np.sin(t)])
    return (
        np.asarray(centre)[:, None] + k * v @ (np.sqrt(np.clip(w, 0, None))[:, None] * circle)
    ).T


def coverage_ellipses(
    names: Sequence[str],
    mean,
    covariance,
    *,
    p: float = 0.95,
    units: Sequence[str] | None = None,
    samples=None,
    mcm_mean=None,
    mcm_covariance=None,
    max_pairs: int = 6,
) -> Figure:
    """Pairwise coverage ellipses of outputs (JCGM 102:2011, 7.7 and 6.5.2).

    For each pair (i, j) the bivariate marginal region
    ``(y − ŷ)ᵀ U⁻¹ (y − ŷ) ≤ k²`` with ``k² = χ²₂(p)`` is drawn for the GUF (and for
    the Monte Carlo estimate and covariance when given), over a thinned scatter of the
    Monte Carlo samples.

    Parameters
    ----------
    names : sequence of str, length m ≥ 2
    mean : (m,) array_like
    covariance : (m, m) array_like
    p : float
        Coverage probability of each pairwise region.
    units : sequence of str, optional
    samples : (M, m) array_like, optional
        Monte Carlo values; at most 2000 are drawn.
    mcm_mean, mcm_covariance : optional
        Monte Carlo estimate and covariance.
    max_pairs : int
        Pairs drawn (the first ones in order (0, 1), (0, 2), ...).

    Examples
    --------
    >>> fig = coverage_ellipses(["x", "y", "z"], [0, 0, 0], __import__("numpy").eye(3))
    >>> len(fig.axes)
    3
    """
    from mtmetrology.uncertainty.normal_coverage import normal_region_coverage

    y = np.asarray(mean, dtype=float)
    cov = np.asarray(covariance, dtype=float)
    m = y.size
    if m < 2 or cov.shape != (m, m) or len(names) != m:
        raise ValueError("coverage ellipses need m >= 2 names, an (m,) mean and (m, m) covariance")
    units = list(units) if units is not None else [""] * m
    pairs = [(i, j) for i in range(m) for j in range(i + 1, m)][:max_pairs]
    k = normal_region_coverage(2, p=p).coverage_factor  # JCGM 102 6.5.2.3, n = 2
    ncols = min(3, len(pairs))
    nrows = -(-len(pairs) // ncols)
    fig = new_figure(3.3 * ncols, 3.1 * nrows)
    thinned = None
    if samples is not None:
        s = np.asarray(samples, dtype=float)
        thinned = s[:: max(1, s.shape[0] // 2000)]
    for n, (i, j) in enumerate(pairs):
        ax = fig.add_subplot(nrows, ncols, n + 1)
        if thinned is not None:
            ax.scatter(
                thinned[:, i], thinned[:, j], s=2, color=GREY, alpha=0.4, lw=0, rasterized=True
            )
        e = _ellipse(y[[i, j]], cov[np.ix_([i, j], [i, j])], k)
        ax.plot(e[:, 0], e[:, 1], color=ORANGE, lw=2, label="GUF")
        if mcm_mean is not None and mcm_covariance is not None:
            mm, mc = np.asarray(mcm_mean, float), np.asarray(mcm_covariance, float)
            e = _ellipse(mm[[i, j]], mc[np.ix_([i, j], [i, j])], k)
            ax.plot(e[:, 0], e[:, 1], color=BLUE, lw=1.5, ls="--", label="Monte Carlo")
        ax.plot(*y[[i, j]], "+", color="black")
        ax.set_xlabel(axis_label(names[i], units[i]), fontsize=8)
        ax.set_ylabel(axis_label(names[j], units[j]), fontsize=8)
        ax.tick_params(labelsize=7)
        if n == 0:
            legend_below(fig, ax, fontsize=7)
    fig.suptitle(f"Pairwise coverage regions, p = {p:g}")
    return plain_ticks(fig)


def budget_bars(
    labels: Sequence[str],
    shares,
    *,
    title: str | None = None,
) -> Figure:
    """Horizontal bars of the shares of u_c²(y), largest magnitude on top.

    ``shares`` are the variance contributions of
    :func:`mtmetrology.uncertainty.guf.variance_shares` (they sum to 1 and may be
    negative with correlated inputs); each bar is labelled with its share in percent, as
    :func:`mtmetrology.formatting.format_share` prints it in the budget table.

    Examples
    --------
    >>> fig = budget_bars(["l_s", "d", "θ"], [0.6, 0.1, 0.3])
    >>> [t.get_text() for t in fig.axes[0].get_yticklabels()]
    ['d', 'θ', 'l_s']
    """
    from mtmetrology.formatting import format_share

    s = np.asarray(shares, dtype=float)
    if s.shape != (len(labels),):
        raise ValueError(f"{len(labels)} labels for {s.size} shares")
    order = np.argsort(np.abs(s), kind="stable")
    fig = new_figure(6.4, 1.2 + 0.32 * len(labels))
    ax = fig.add_subplot()
    pct = 100.0 * s
    ax.barh(
        [labels[i] for i in order],
        pct[order],
        color=[BLUE if v >= 0 else ORANGE for v in pct[order]],
    )
    for pos, i in enumerate(order):
        ax.text(pct[i], pos, f" {format_share(s[i])}", va="center", fontsize=8)
    ax.axvline(0.0, color="black", lw=0.8)
    low = min(0.0, float(pct.min())) if pct.size else 0.0
    high = max(0.0, float(pct.max())) if pct.size else 1.0
    ax.set_xlim(1.25 * low, 1.25 * high if high > 0 else 1.0)
    ax.set_xlabel("share of u_c²(y), %")
    ax.set_title(title or "Uncertainty budget")
    return plain_ticks(fig)


def conformity_zones(
    value: float,
    U: float,
    lower: float | None,
    upper: float | None,
    *,
    name: str = "",
    unit: str = "",
    nominal: float | None = None,
) -> Figure:
    """A measured value ± U against its specification zone (ISO 14253-1:2017).

    The specification zone [lower, upper] is drawn with its conformance zone (shrunk
    by U at each specified limit, where conformity is proven) and the nonconformance
    zones beyond the limits widened by U (where nonconformity is proven); between them
    neither is proven. One limit may be None (a one-sided specification).

    Parameters
    ----------
    value, U, lower, upper : float
        The value, its expanded uncertainty and the limits, in ``unit``.
    name, unit : str
    nominal : float, optional
        The nominal value: the axis then shows deviations from it in the display unit
        of ``unit`` (µm for mm), ``name − nominal``, rather than ``value`` itself, whose
        ticks would differ in their last digits only.

    Examples
    --------
    >>> fig = conformity_zones(10.002, 0.003, 9.990, 10.010, name="length", unit="mm")
    >>> fig.axes[0].get_title()
    'length = 10.0020 ± 0.0030 mm: conformity proven'
    >>> fig = conformity_zones(10.002, 0.003, 9.990, 10.010, name="length", unit="mm",
    ...                        nominal=10.0)
    >>> fig.axes[0].get_xlabel(), tuple(round(float(x), 6) for x in fig.axes[0].get_xlim())
    ('length − 10 mm (µm)', (-17.0, 17.0))
    """
    if lower is None and upper is None:
        raise ValueError("a specification needs at least one limit")
    if not U >= 0:
        raise ValueError(f"U must be >= 0, got {U}")
    lo = -np.inf if lower is None else float(lower)
    hi = np.inf if upper is None else float(upper)
    if lo >= hi:
        raise ValueError(f"lower limit {lower} must be below upper limit {upper}")
    if lo + U <= value <= hi - U:
        decision = "conformity proven"
    elif value < lo - U or value > hi + U:
        decision = "nonconformity proven"
    else:
        decision = "neither conformity nor nonconformity proven"
    finite = [v for v in (lo, hi) if np.isfinite(v)]
    span = (max(finite) - min(finite)) if len(finite) == 2 else max(4 * U, abs(value) * 1e-3, 1e-9)
    left = min([*finite, value - U]) - 0.35 * span
    right = max([*finite, value + U]) + 0.35 * span
    title = f"{format_value(value, U / 2)} ± {format_uncertainty(U)}"
    title = f"{name + ' = ' if name else ''}{title}{' ' + unit if unit else ''}: {decision}"
    xlabel = axis_label(name or "value", unit)
    if nominal is not None:
        # the axis in deviations from the nominal, in the display unit (µm for mm)
        shown = display_unit(unit) if unit else unit
        scale = float(convert(1.0, unit, shown)) if unit else 1.0
        xlabel = axis_label(f"{name or 'value'} − {nominal:g}{' ' + unit if unit else ''}", shown)
        lo, hi, value, left, right = ((v - nominal) * scale for v in (lo, hi, value, left, right))
        finite, U = [(v - nominal) * scale for v in finite], U * scale
    fig = new_figure(6.4, 2.4)
    ax = fig.add_subplot()
    a, b = max(lo, left), min(hi, right)
    ax.axvspan(a, b, color=GREEN, alpha=0.15, label="specification zone")
    if a + U < b - U:
        ax.axvspan(
            a + U if np.isfinite(lo) else a,
            b - U if np.isfinite(hi) else b,
            color=GREEN,
            alpha=0.35,
            label="conformance zone",
        )
    if np.isfinite(lo):
        ax.axvspan(left, lo - U, color=RED, alpha=0.25, label="nonconformance zone")
    if np.isfinite(hi):
        ax.axvspan(
            hi + U,
            right,
            color=RED,
            alpha=0.25,
            label=None if np.isfinite(lo) else "nonconformance zone",
        )
    for limit in finite:
        ax.axvline(limit, color="black", lw=1)
    ax.errorbar([value], [0.5], xerr=[[U], [U]], fmt="o", color=BLUE, capsize=6, label="value ± U")
    ax.set_xlim(left, right)
    ax.set_ylim(0, 1)
    ax.set_yticks([])
    ax.set_xlabel(xlabel)
    ax.set_title(title)
    legend_below(fig, ax, fontsize=7)
    return plain_ticks(fig)
