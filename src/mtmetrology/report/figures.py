"""The figures of mtmetrology reports, as matplotlib :class:`~matplotlib.figure.Figure`.

Every function returns a new figure built without :mod:`matplotlib.pyplot` (no global
state, no display needed: the figures render with the Agg/SVG canvases on a headless
machine) and takes quantities in the units it prints: callers convert with
:mod:`mtmetrology.units` before plotting (µm, µrad, µm/m, mm, degrees). Pass the figure
to :meth:`mtmetrology.report.Report.figure`, or show it in a notebook.

References
----------
JCGM 100:2008, *Evaluation of measurement data — Guide to the expression of uncertainty
in measurement* (budgets, 7.2.6 rounding). JCGM 101:2008, *Propagation of distributions
using a Monte Carlo method* (histogram against the GUF PDF, 9). JCGM 102:2011,
*Extension to any number of output quantities* (coverage regions, 7.7). ISO
14253-1:2017, *Decision rules for verifying conformity or nonconformity with
specifications* (conformance and nonconformance zones).
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import UTC

import numpy as np
from matplotlib.figure import Figure

from mtmetrology.formatting import format_uncertainty, format_value

__all__ = [
    "budget_bars",
    "conformity_zones",
    "control_chart",
    "convergence",
    "correlation_heatmap",
    "coverage_ellipses",
    "error_map",
    "histogram_vs_normal",
    "hysteresis_bars",
    "length_errors",
    "parameter_table_columns",
    "parameter_table_rows",
    "point_deviations",
    "residual_profile",
    "residual_vectors",
    "singular_values",
    "window_repeatability",
]

_BLUE, _ORANGE, _GREEN, _RED, _GREY = "#2a5d8f", "#d9822b", "#3f8f4a", "#b8383b", "#8c959f"


def _figure(width: float = 6.4, height: float = 3.8) -> Figure:
    return Figure(figsize=(width, height), layout="constrained")


def _label(name: str, unit: str) -> str:
    return f"{name} ({unit})" if unit else name


# -- tables ------------------------------------------------------------------------------
def parameter_table_columns(coverage_factor: float = 2.0) -> list[str]:
    """Column headings matching :func:`parameter_table_rows`."""
    return ["parameter", "value", "unit", "u", f"U (k = {coverage_factor:g})"]


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


# -- uncertainty -------------------------------------------------------------------------
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
    fig = _figure(size + 1.2, size)
    ax = fig.add_subplot()
    image = ax.imshow(r, cmap="RdBu_r", vmin=-1.0, vmax=1.0)
    ax.set_xticks(range(n), names, rotation=90, fontsize=8)
    ax.set_yticks(range(n), names, fontsize=8)
    if n <= 16:
        for i in range(n):
            for j in range(n):
                colour = "white" if abs(r[i, j]) > 0.6 else "black"
                ax.text(j, i, f"{r[i, j]:.2f}", ha="center", va="center", fontsize=7, color=colour)
    fig.colorbar(image, ax=ax, shrink=0.8, label="correlation coefficient")
    ax.set_title(title or "Correlation of the estimates")
    return fig


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
    fig = _figure()
    ax = fig.add_subplot()
    ax.stairs(density, edges, fill=True, color=_BLUE, alpha=0.45, label="Monte Carlo")
    x = np.linspace(min(edges[0], mean - 4 * u), max(edges[-1], mean + 4 * u), 400)
    if dof is not None and np.isfinite(dof):
        pdf, law = stats.t.pdf((x - mean) / u, dof) / u, f"GUF: t, ν = {dof:.3g}"
    else:
        pdf, law = stats.norm.pdf(x, mean, u), "GUF: normal"
    ax.plot(x, pdf, color=_ORANGE, lw=2, label=law)
    for bounds, colour, label in (
        (interval, _BLUE, "Monte Carlo interval"),
        (guf_interval, _ORANGE, "GUF interval"),
    ):
        if bounds is not None:
            for k, b in enumerate(bounds):
                ax.axvline(b, color=colour, ls="--", lw=1, label=label if k == 0 else None)
    ax.set_xlabel(_label(name, unit))
    ax.set_ylabel("probability density")
    ax.set_title(f"Distribution of {name}")
    ax.legend(fontsize=8)
    return fig


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
    from scipy import stats

    y = np.asarray(mean, dtype=float)
    cov = np.asarray(covariance, dtype=float)
    m = y.size
    if m < 2 or cov.shape != (m, m) or len(names) != m:
        raise ValueError("coverage ellipses need m >= 2 names, an (m,) mean and (m, m) covariance")
    units = list(units) if units is not None else [""] * m
    pairs = [(i, j) for i in range(m) for j in range(i + 1, m)][:max_pairs]
    k = float(np.sqrt(stats.chi2.ppf(p, 2)))
    ncols = min(3, len(pairs))
    nrows = -(-len(pairs) // ncols)
    fig = _figure(3.3 * ncols, 3.1 * nrows)
    thinned = None
    if samples is not None:
        s = np.asarray(samples, dtype=float)
        thinned = s[:: max(1, s.shape[0] // 2000)]
    for n, (i, j) in enumerate(pairs):
        ax = fig.add_subplot(nrows, ncols, n + 1)
        if thinned is not None:
            ax.scatter(
                thinned[:, i], thinned[:, j], s=2, color=_GREY, alpha=0.4, lw=0, rasterized=True
            )
        e = _ellipse(y[[i, j]], cov[np.ix_([i, j], [i, j])], k)
        ax.plot(e[:, 0], e[:, 1], color=_ORANGE, lw=2, label="GUF")
        if mcm_mean is not None and mcm_covariance is not None:
            mm, mc = np.asarray(mcm_mean, float), np.asarray(mcm_covariance, float)
            e = _ellipse(mm[[i, j]], mc[np.ix_([i, j], [i, j])], k)
            ax.plot(e[:, 0], e[:, 1], color=_BLUE, lw=1.5, ls="--", label="Monte Carlo")
        ax.plot(*y[[i, j]], "+", color="black")
        ax.set_xlabel(_label(names[i], units[i]), fontsize=8)
        ax.set_ylabel(_label(names[j], units[j]), fontsize=8)
        ax.tick_params(labelsize=7)
        if n == 0:
            ax.legend(fontsize=7)
    fig.suptitle(f"Pairwise coverage regions, p = {p:g}")
    return fig


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
    fig = _figure(6.4, 1.2 + 0.32 * len(labels))
    ax = fig.add_subplot()
    pct = 100.0 * s
    ax.barh(
        [labels[i] for i in order],
        pct[order],
        color=[_BLUE if v >= 0 else _ORANGE for v in pct[order]],
    )
    for pos, i in enumerate(order):
        ax.text(pct[i], pos, f" {format_share(s[i])}", va="center", fontsize=8)
    ax.axvline(0.0, color="black", lw=0.8)
    low = min(0.0, float(pct.min())) if pct.size else 0.0
    high = max(0.0, float(pct.max())) if pct.size else 1.0
    ax.set_xlim(1.25 * low, 1.25 * high if high > 0 else 1.0)
    ax.set_xlabel("share of u_c²(y), %")
    ax.set_title(title or "Uncertainty budget")
    return fig


def conformity_zones(
    value: float,
    U: float,
    lower: float | None,
    upper: float | None,
    *,
    name: str = "",
    unit: str = "",
) -> Figure:
    """A measured value ± U against its specification zone (ISO 14253-1:2017).

    The specification zone [lower, upper] is drawn with its conformance zone (shrunk
    by U at each specified limit, where conformity is proven) and the nonconformance
    zones beyond the limits widened by U (where nonconformity is proven); between them
    neither is proven. One limit may be None (a one-sided specification).

    Examples
    --------
    >>> fig = conformity_zones(10.002, 0.003, 9.990, 10.010, name="length", unit="mm")
    >>> fig.axes[0].get_title()
    'length = 10.0020 ± 0.0030 mm: conformity proven'
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
    fig = _figure(6.4, 2.4)
    ax = fig.add_subplot()
    a, b = max(lo, left), min(hi, right)
    ax.axvspan(a, b, color=_GREEN, alpha=0.15, label="specification zone")
    if a + U < b - U:
        ax.axvspan(
            a + U if np.isfinite(lo) else a,
            b - U if np.isfinite(hi) else b,
            color=_GREEN,
            alpha=0.35,
            label="conformance zone",
        )
    if np.isfinite(lo):
        ax.axvspan(left, lo - U, color=_RED, alpha=0.25, label="nonconformance zone")
    if np.isfinite(hi):
        ax.axvspan(
            hi + U,
            right,
            color=_RED,
            alpha=0.25,
            label=None if np.isfinite(lo) else "nonconformance zone",
        )
    for limit in finite:
        ax.axvline(limit, color="black", lw=1)
    ax.errorbar([value], [0.5], xerr=[[U], [U]], fmt="o", color=_BLUE, capsize=6, label="value ± U")
    ax.set_xlim(left, right)
    ax.set_ylim(0, 1)
    ax.set_yticks([])
    ax.set_xlabel(_label(name or "value", unit))
    text = f"{format_value(value, U / 2)} ± {format_uncertainty(U)}"
    ax.set_title(f"{name + ' = ' if name else ''}{text}{' ' + unit if unit else ''}: {decision}")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.35), ncol=4)
    return fig


# -- machines and artefacts ----------------------------------------------------------------
def residual_vectors(
    points,
    residuals,
    *,
    unit: str = "µm",
    magnification: float | None = None,
    labels: Sequence[str] | None = None,
    title: str | None = None,
) -> Figure:
    """Residual vectors on an artefact, in the XY, XZ and YZ projections.

    Parameters
    ----------
    points : (n, 3) array_like, mm
        Where the residuals are (ball centres, probed points).
    residuals : (n, 3) array_like, in ``unit``
        Measured minus modelled position at each point.
    unit : str
        Unit of the residuals (µm by default).
    magnification : float, optional
        Arrow length per unit of residual, mm per ``unit``; by default the largest
        arrow is a tenth of the artefact's extent.
    labels : sequence of str, optional
        Names written beside the points (ball ids).

    Examples
    --------
    >>> import numpy as np
    >>> fig = residual_vectors(np.eye(3) * 100, np.eye(3), labels=["1", "2", "3"])
    >>> [ax.get_title() for ax in fig.axes]
    ['XY', 'XZ', 'YZ']
    """
    x = np.asarray(points, dtype=float)
    r = np.asarray(residuals, dtype=float)
    if x.ndim != 2 or x.shape[1] != 3 or r.shape != x.shape:
        raise ValueError(f"points and residuals must both be (n, 3), got {x.shape} and {r.shape}")
    longest = float(np.max(np.linalg.norm(r, axis=1))) if r.size else 0.0
    extent = float(np.max(np.ptp(x, axis=0))) if len(x) > 1 else 1.0
    if magnification is None:
        magnification = 0.1 * (extent or 1.0) / longest if longest > 0 else 1.0
    fig = _figure(10.0, 3.7)
    for n, (i, j, plane) in enumerate(((0, 1, "XY"), (0, 2, "XZ"), (1, 2, "YZ"))):
        ax = fig.add_subplot(1, 3, n + 1)
        ax.plot(x[:, i], x[:, j], "o", color=_GREY, ms=4)
        ax.quiver(
            x[:, i],
            x[:, j],
            magnification * r[:, i],
            magnification * r[:, j],
            angles="xy",
            scale_units="xy",
            scale=1,
            color=_RED,
            width=0.006,
        )
        if labels is not None:
            for k, text in enumerate(labels):
                ax.annotate(
                    str(text),
                    (x[k, i], x[k, j]),
                    fontsize=7,
                    textcoords="offset points",
                    xytext=(3, 3),
                )
        ax.set_xlabel(f"{plane[0].lower()} (mm)")
        ax.set_ylabel(f"{plane[1].lower()} (mm)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(plane)
        ax.tick_params(labelsize=7)
    fig.suptitle(
        (title or "Residual vectors")
        + f" (largest {longest:.3g} {unit}; arrows x{magnification:.3g} mm per {unit})",
        fontsize=10,
    )
    return fig


def point_deviations(points, deviations, *, unit: str = "µm", title: str | None = None) -> Figure:
    """Points in the XY, XZ and YZ projections, coloured by their signed deviation.

    Parameters
    ----------
    points : (n, 3) array_like, mm
    deviations : (n,) array_like, in ``unit``
        Signed normal distances to a fitted element (positive outside the material).

    Examples
    --------
    >>> import numpy as np
    >>> fig = point_deviations(np.eye(3), [1.0, -1.0, 0.5])
    >>> fig.axes[-1].get_ylabel()
    'deviation (µm)'
    """
    x = np.asarray(points, dtype=float)
    d = np.asarray(deviations, dtype=float)
    if x.ndim != 2 or x.shape[1] != 3 or d.shape != (x.shape[0],):
        raise ValueError(f"points (n, 3) and deviations (n,) expected, got {x.shape}, {d.shape}")
    limit = float(np.max(np.abs(d))) or 1.0
    fig = _figure(10.0, 3.5)
    axes = [fig.add_subplot(1, 3, n + 1) for n in range(3)]
    for ax, (i, j, plane) in zip(axes, ((0, 1, "XY"), (0, 2, "XZ"), (1, 2, "YZ")), strict=True):
        image = ax.scatter(x[:, i], x[:, j], c=d, cmap="coolwarm", vmin=-limit, vmax=limit, s=16)
        ax.set_xlabel(f"{plane[0].lower()} (mm)")
        ax.set_ylabel(f"{plane[1].lower()} (mm)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(plane)
        ax.tick_params(labelsize=7)
    fig.colorbar(image, ax=axes, label=_label("deviation", unit), shrink=0.85)
    fig.suptitle(title or "Deviations from the fitted element", fontsize=10)
    return fig


def residual_profile(residuals, *, unit: str = "µm", title: str | None = None) -> Figure:
    """Signed residuals in their order (probing sequence), with their extreme values.

    Examples
    --------
    >>> fig = residual_profile([0.5, -1.0, 0.25])
    >>> fig.axes[0].get_ylabel()
    'residual (µm)'
    """
    r = np.asarray(residuals, dtype=float).ravel()
    if r.size == 0:
        raise ValueError("no residuals to draw")
    fig = _figure(6.4, 2.8)
    ax = fig.add_subplot()
    index = np.arange(1, r.size + 1)
    ax.vlines(index, 0.0, r, color=_BLUE, lw=1.2)
    ax.plot(index, r, "o", color=_BLUE, ms=3)
    ax.axhline(0.0, color="black", lw=0.8)
    for v in (r.min(), r.max()):
        ax.axhline(v, color=_GREY, ls=":", lw=1)
    ax.set_xlabel("point")
    ax.set_ylabel(_label("residual", unit))
    ax.set_title(title or f"Residuals (range {r.max() - r.min():.3g} {unit})")
    return fig


def error_map(
    x,
    y,
    values,
    *,
    name: str = "error",
    unit: str = "µm",
    xlabel: str = "x (mm)",
    ylabel: str = "y (mm)",
    title: str | None = None,
) -> Figure:
    """A map of an error over a plane of the workspace.

    Parameters
    ----------
    x, y : array_like
        Grid coordinates: 1-D of lengths nx and ny with ``values`` of shape (ny, nx), or
        scattered points of the same shape as ``values`` (n ≥ 3, not collinear).
    values : array_like
        The error (e.g. the volumetric error norm) in ``unit``.

    Examples
    --------
    >>> import numpy as np
    >>> gx, gy = np.linspace(0, 400, 5), np.linspace(0, 300, 4)
    >>> fig = error_map(gx, gy, np.add.outer(gy, gx) / 100.0)
    >>> fig.axes[1].get_ylabel()
    'error (µm)'
    """
    xa, ya, v = (np.asarray(a, dtype=float) for a in (x, y, values))
    fig = _figure(6.4, 4.6)
    ax = fig.add_subplot()
    if xa.ndim == 1 and ya.ndim == 1 and v.shape == (ya.size, xa.size):
        image = ax.pcolormesh(xa, ya, v, shading="nearest", cmap="viridis", rasterized=True)
    elif xa.shape == ya.shape == v.shape and v.ndim == 1 and v.size >= 3:
        image = ax.tricontourf(xa, ya, v, levels=14, cmap="viridis")
        ax.plot(xa, ya, ".", color="white", ms=2)
    else:
        raise ValueError(
            "error_map needs 1-D x (nx), y (ny) with values (ny, nx), or three 1-D arrays "
            f"of one length >= 3; got {xa.shape}, {ya.shape}, {v.shape}"
        )
    fig.colorbar(image, ax=ax, label=_label(name, unit))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_aspect("equal", adjustable="box")
    ax.set_title(title or f"{name} over the workspace")
    return fig


def singular_values(values, *, title: str | None = None) -> Figure:
    """Singular values of a (column-scaled) identification Jacobian, on a log scale.

    A gap of many decades before the last values marks parameters that the set-up does
    not identify.

    Examples
    --------
    >>> fig = singular_values([3.0, 1.0, 0.2, 1e-12])
    >>> fig.axes[0].get_yscale()
    'log'
    """
    s = np.asarray(values, dtype=float)
    if s.ndim != 1 or s.size == 0:
        raise ValueError("singular values must be a non-empty 1-D array")
    fig = _figure(6.4, 3.2)
    ax = fig.add_subplot()
    floor = s[s > 0].min() * 0.1 if np.any(s > 0) else 1e-16
    ax.semilogy(np.arange(1, s.size + 1), np.maximum(s, floor), "o-", color=_BLUE)
    ax.set_xlabel("index")
    ax.set_ylabel("singular value")
    ax.set_title(title or "Singular values of the scaled Jacobian")
    ax.grid(True, which="both", alpha=0.3)
    return fig


def convergence(
    history,
    *,
    labels: Sequence[str] | None = None,
    xlabel: str = "exchange",
    ylabel: str = "criterion",
    log: bool = False,
    title: str | None = None,
) -> Figure:
    """The criterion of an iterative design (DETMAX) or solver against its iterations.

    Parameters
    ----------
    history : (n,) array_like or sequence of them
        One curve, or one per restart.
    labels : sequence of str, optional
        Names of the curves.

    Examples
    --------
    >>> fig = convergence([[1.0, 2.0, 2.5], [0.5, 2.2, 2.6, 2.6]], ylabel="det^(1/p)")
    >>> len(fig.axes[0].lines)
    2
    """
    scalar_items = not isinstance(history[0], Sequence | np.ndarray)
    curves = [history] if scalar_items else list(history)
    fig = _figure(6.4, 3.4)
    ax = fig.add_subplot()
    for n, curve in enumerate(curves):
        c = np.asarray(curve, dtype=float)
        label = labels[n] if labels is not None else (f"run {n + 1}" if len(curves) > 1 else None)
        ax.plot(np.arange(c.size), c, marker=".", label=label)
    if log:
        ax.set_yscale("log")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title or "Convergence")
    ax.grid(True, alpha=0.3)
    if labels is not None or len(curves) > 1:
        ax.legend(fontsize=8)
    return fig


def length_errors(
    models,
    *,
    coverage_factor: float = 2.0,
    unit: str = "µm",
    title: str | None = None,
) -> Figure:
    """Length errors of several error models against length, with their ±k·u bands.

    One panel per model, sharing the error axis: each length is a point (its error) with
    a bar of ±k u (the model's predicted standard uncertainty of that length); a point
    outside its bar is a length the model's uncertainty does not cover. The fraction
    covered is printed in the panel's title.

    Parameters
    ----------
    models : mapping of str to mapping
        ``{model: {"length_mm": (n,), "error_um": (n,), "u_um": (n,)}}``: reference
        length (mm), error of the measured length and its standard uncertainty (in
        ``unit``), as the ``plot`` of :class:`mtmetrology.cmm.compare.ModelComparison`.
    coverage_factor : float
        k of the bars.

    Examples
    --------
    >>> fig = length_errors({"a": {"length_mm": [100, 200], "error_um": [1.0, -3.0],
    ...                            "u_um": [1.0, 1.0]}})
    >>> fig.axes[0].get_title()
    'a: 50 % within ±2u'
    """
    names = list(models)
    if not names:
        raise ValueError("length_errors needs at least one model")
    fig = _figure(3.4 * len(names) + 0.6, 3.6)
    axes = fig.subplots(1, len(names), sharey=True, squeeze=False)[0]
    for ax, name in zip(axes, names, strict=True):
        d = models[name]
        length, err, u = (np.asarray(d[k], dtype=float) for k in ("length_mm", "error_um", "u_um"))
        if not (length.shape == err.shape == u.shape and length.ndim == 1):
            raise ValueError(f"{name}: length_mm, error_um and u_um must be 1-D of one length")
        inside = np.abs(err) <= coverage_factor * u
        ax.errorbar(length, err, yerr=coverage_factor * u, fmt="none", ecolor=_GREY, elinewidth=0.8)
        ax.plot(length[inside], err[inside], "o", color=_BLUE, ms=3)
        ax.plot(length[~inside], err[~inside], "o", color=_RED, ms=3)
        ax.axhline(0.0, color="black", lw=0.6)
        share = 100.0 * float(np.mean(inside)) if inside.size else 0.0
        ax.set_title(f"{name}: {share:.0f} % within ±{coverage_factor:g}u", fontsize=9)
        ax.set_xlabel("length (mm)")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel(_label("length error", unit))
    fig.suptitle(title or "Length errors and ±k·u of each model", fontsize=10)
    return fig


def window_repeatability(
    series, *, window: int, unit: str = "µm", title: str | None = None
) -> Figure:
    """Standard deviation in a sliding window against the window's first iteration.

    One panel per coordinate; one thin line per target and, thick, the median over the
    targets at each window start (Sepahi Boroujeni (2021), §4, Fig. 4-20).

    Parameters
    ----------
    series : mapping of str to sequence of (starts, std)
        ``{coordinate: [(starts (n_w,), std (n_w,)), ...]}``, one pair per target: the
        first iteration of each window and the standard deviation in it (``unit``).
    window : int
        Touches per window (for the title).

    Examples
    --------
    >>> fig = window_repeatability({"sigma_X": [([2, 3], [0.5, 0.6]), ([2, 3], [0.4, 0.7])]},
    ...                            window=10)
    >>> fig.axes[0].get_ylabel()
    'sigma_X (µm)'
    """
    names = list(series)
    if not names or not all(series[n] for n in names):
        raise ValueError("window_repeatability needs at least one target per coordinate")
    fig = _figure(3.2 * len(names) + 0.6, 3.2)
    axes = fig.subplots(1, len(names), sharey=True, squeeze=False)[0]
    for ax, name in zip(axes, names, strict=True):
        by_start: dict[int, list[float]] = {}
        for starts, std in series[name]:
            ax.plot(starts, std, color=_GREY, lw=0.6, alpha=0.6)
            for k, v in zip(starts, std, strict=True):
                by_start.setdefault(int(k), []).append(float(v))
        grid = sorted(by_start)
        ax.plot(grid, [np.median(by_start[k]) for k in grid], color=_BLUE, lw=2, label="median")
        ax.set_xlabel("window start (iteration)")
        ax.set_ylabel(_label(name, unit))
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.suptitle(title or f"Repeatability in a {window}-touch sliding window", fontsize=10)
    return fig


def hysteresis_bars(
    psi_deg, hysteresis, u, *, coverage_factor=2.0, unit: str = "µm", title: str | None = None
) -> Figure:
    """Hysteresis error of each indexation with its ±k·u bar (Sepahi Boroujeni (2021), Fig. 4-16b).

    Parameters
    ----------
    psi_deg : (m,) array_like, deg
        Indexations.
    hysteresis, u : (m,) array_like
        H_ψ and u(H_ψ) in ``unit``.
    coverage_factor : float or (m,) array_like
        k of each bar.

    Examples
    --------
    >>> fig = hysteresis_bars([0, 30], [0.1, -0.2], [0.15, 0.2])
    >>> fig.axes[0].get_xlabel()
    'ψ (deg)'
    """
    psi = np.asarray(psi_deg, dtype=float)
    h = np.asarray(hysteresis, dtype=float)
    half = np.broadcast_to(np.asarray(coverage_factor, dtype=float), h.shape) * np.asarray(
        u, dtype=float
    )
    if not (psi.shape == h.shape == half.shape and psi.ndim == 1 and psi.size):
        raise ValueError("psi_deg, hysteresis and u must be 1-D of one non-zero length")
    fig = _figure(6.4, 3.2)
    ax = fig.add_subplot()
    width = 0.6 * float(np.min(np.diff(psi))) if psi.size > 1 else 10.0
    ax.bar(psi, h, width=width, color=_BLUE, alpha=0.8)
    ax.errorbar(psi, h, yerr=half, fmt="none", ecolor="black", elinewidth=1, capsize=3)
    ax.axhline(0.0, color="black", lw=0.6)
    ax.set_xlabel("ψ (deg)")
    ax.set_ylabel(_label("hysteresis error H", unit))
    ax.grid(True, axis="y", alpha=0.3)
    ax.set_title(title or "Hysteresis error per indexation, bars ±U")
    return fig


def _utc_datetime64(dates) -> np.ndarray:
    """datetime64 (UTC, seconds) of datetimes, aware (converted) or naive (taken as UTC)."""
    return np.array(
        [
            np.datetime64((d.astimezone(UTC) if d.tzinfo else d).replace(tzinfo=None), "s")
            for d in dates
        ]
    )


def control_chart(
    dates,
    values,
    centre: float,
    limits: tuple[float, float],
    out_of_control,
    *,
    name: str,
    unit: str,
    prediction=None,
    mpe: float | None = None,
    due_date=None,
) -> Figure:
    """Individuals control chart of a parameter over time (ISO 7870-2): the values, the
    centre line and the ±3σ control limits, out-of-control points in red; optionally a
    prediction ``(dates, mean, half_width)`` band, the ±MPE lines and the due date."""
    fig = _figure(7.2, 3.8)
    ax = fig.add_subplot()
    flags = np.asarray(out_of_control, dtype=bool)
    values = np.asarray(values, dtype=float)
    dates = _utc_datetime64(dates)
    ax.plot(dates, values, "o-", color=_BLUE, ms=3, lw=0.8, label=name)
    ax.plot(dates[flags], values[flags], "o", color=_RED, ms=6, label="out of control")
    ax.axhline(centre, color=_GREY, lw=1, label="centre")
    for limit in limits:
        ax.axhline(limit, color=_ORANGE, lw=1, ls="--")
    if prediction is not None:
        when, mean, half = prediction
        when = _utc_datetime64(when)
        ax.plot(when, mean, color=_GREEN, lw=1, label="prediction")
        ax.fill_between(when, mean - half, mean + half, color=_GREEN, alpha=0.2, lw=0)
    if mpe is not None:
        for bound in (-mpe, mpe):
            ax.axhline(bound, color=_RED, lw=1)
    if due_date is not None:
        ax.axvline(
            np.datetime64(due_date.replace(tzinfo=None), "s"), color=_RED, ls=":", label="due"
        )
    ax.set_ylabel(_label(name, unit))
    ax.legend(fontsize="small", loc="best")
    return fig
