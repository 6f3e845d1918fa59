"""Figures of machines and artefacts: residual vectors and point deviations of a fit,
residual profiles, error maps, length errors, the singular values of an identification
and the convergence of an iterative design or solver."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import ScalarFormatter

from mtmetrology.report.figures.style import (
    BLUE,
    GREY,
    RED,
    axis_label,
    legend_below,
    new_figure,
    plain_ticks,
)

__all__ = [
    "circular_trace",
    "convergence",
    "error_map",
    "length_errors",
    "point_deviations",
    "residual_profile",
    "residual_vectors",
    "singular_values",
]


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
    fig = new_figure(10.0, 3.7)
    for n, (i, j, plane) in enumerate(((0, 1, "XY"), (0, 2, "XZ"), (1, 2, "YZ"))):
        ax = fig.add_subplot(1, 3, n + 1)
        ax.plot(x[:, i], x[:, j], "o", color=GREY, ms=4)
        # the limits hold the arrow tips as well as the points (quiver does not autoscale
        # to its tips), with a margin for the markers and the labels beside them
        tips = x[:, [i, j]] + magnification * r[:, [i, j]]
        ax.update_datalim(tips)
        ax.margins(0.15)
        ax.quiver(
            x[:, i],
            x[:, j],
            magnification * r[:, i],
            magnification * r[:, j],
            angles="xy",
            scale_units="xy",
            scale=1,
            color=RED,
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
    return plain_ticks(fig)


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
    fig = new_figure(10.0, 3.5)
    axes = [fig.add_subplot(1, 3, n + 1) for n in range(3)]
    for ax, (i, j, plane) in zip(axes, ((0, 1, "XY"), (0, 2, "XZ"), (1, 2, "YZ")), strict=True):
        image = ax.scatter(x[:, i], x[:, j], c=d, cmap="coolwarm", vmin=-limit, vmax=limit, s=16)
        ax.set_xlabel(f"{plane[0].lower()} (mm)")
        ax.set_ylabel(f"{plane[1].lower()} (mm)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(plane)
        ax.tick_params(labelsize=7)
    fig.colorbar(image, ax=axes, label=axis_label("deviation", unit), shrink=0.85)
    fig.suptitle(title or "Deviations from the fitted element", fontsize=10)
    return plain_ticks(fig)


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
    fig = new_figure(6.4, 2.8)
    ax = fig.add_subplot()
    index = np.arange(1, r.size + 1)
    ax.vlines(index, 0.0, r, color=BLUE, lw=1.2)
    ax.plot(index, r, "o", color=BLUE, ms=3)
    ax.axhline(0.0, color="black", lw=0.8)
    for v in (r.min(), r.max()):
        ax.axhline(v, color=GREY, ls=":", lw=1)
    ax.set_xlabel("point")
    ax.set_ylabel(axis_label("residual", unit))
    ax.set_title(title or f"Residuals (range {r.max() - r.min():.3g} {unit})")
    return plain_ticks(fig)


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
    fig = new_figure(6.4, 4.6)
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
    fig.colorbar(image, ax=ax, label=axis_label(name, unit))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_aspect("equal", adjustable="box")
    ax.set_title(title or f"{name} over the workspace")
    return plain_ticks(fig)


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
    fig = new_figure(6.4, 3.2)
    ax = fig.add_subplot()
    floor = s[s > 0].min() * 0.1 if np.any(s > 0) else 1e-16
    ax.semilogy(np.arange(1, s.size + 1), np.maximum(s, floor), "o-", color=BLUE)
    ax.set_xlabel("index")
    ax.set_ylabel("singular value")
    ax.set_title(title or "Singular values of the scaled Jacobian")
    ax.grid(True, which="both", alpha=0.3)
    return plain_ticks(fig)


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
    fig = new_figure(6.4, 3.4)
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
        legend_below(fig, ax)
    return plain_ticks(fig)


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
    fig = new_figure(3.4 * len(names) + 0.6, 3.6)
    axes = fig.subplots(1, len(names), sharey=True, squeeze=False)[0]
    for ax, name in zip(axes, names, strict=True):
        d = models[name]
        length, err, u = (np.asarray(d[k], dtype=float) for k in ("length_mm", "error_um", "u_um"))
        if not (length.shape == err.shape == u.shape and length.ndim == 1):
            raise ValueError(f"{name}: length_mm, error_um and u_um must be 1-D of one length")
        inside = np.abs(err) <= coverage_factor * u
        ax.errorbar(length, err, yerr=coverage_factor * u, fmt="none", ecolor=GREY, elinewidth=0.8)
        ax.plot(length[inside], err[inside], "o", color=BLUE, ms=3)
        ax.plot(length[~inside], err[~inside], "o", color=RED, ms=3)
        ax.axhline(0.0, color="black", lw=0.6)
        share = 100.0 * float(np.mean(inside)) if inside.size else 0.0
        ax.set_title(f"{name}: {share:.0f} % within ±{coverage_factor:g}u", fontsize=9)
        ax.set_xlabel("length (mm)")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel(axis_label("length error", unit))
    fig.suptitle(title or "Length errors and ±k·u of each model", fontsize=10)
    return plain_ticks(fig)


def circular_trace(
    angle_deg, deviations: Mapping[str, object], *, unit: str = "µm", title: str | None = None
) -> Figure:
    """The polar plot of a circular test: the radial deviation of each run against its
    angle, the nominal circle at the zero ring (ISO 230-4 presentation).

    Parameters
    ----------
    angle_deg : mapping or array_like
        Angles (degrees) of each run's samples, a mapping with the keys of ``deviations``
        or one array shared by all runs.
    deviations : mapping of str to array_like
        Radial deviation per run (e.g. ``{"ccw": …, "cw": …}``), in ``unit``.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.arange(0, 360, 10.0)
    >>> fig = circular_trace(a, {"ccw": np.cos(np.radians(2 * a)), "cw": 0 * a})
    >>> fig.axes[0].name, len(fig.axes[0].lines)
    ('polar', 3)
    """
    if not deviations:
        raise ValueError("no run to draw")
    runs = {k: np.asarray(v, dtype=float).ravel() for k, v in deviations.items()}
    angles = {
        k: np.asarray(angle_deg[k] if isinstance(angle_deg, Mapping) else angle_deg, dtype=float)
        for k in runs
    }
    low = min(v.min() for v in runs.values())
    high = max(v.max() for v in runs.values())
    span = max(high - low, 1e-12)
    fig = new_figure(4.8, 4.8)
    ax = fig.add_subplot(projection="polar")
    # the zero ring is the nominal circle: the origin sits one span inside the lowest value
    ax.set_rorigin(low - span)
    ax.set_ylim(low - 0.1 * span, high + 0.1 * span)
    ring = np.linspace(0.0, 2.0 * np.pi, 361)
    ax.plot(ring, np.zeros_like(ring), color=GREY, lw=0.8)
    for (name, dev), colour in zip(runs.items(), (BLUE, RED, GREY), strict=False):
        order = np.argsort(angles[name])
        theta = np.radians(angles[name][order])
        ax.plot(np.append(theta, theta[0]), np.append(dev[order], dev[order][0]), color=colour,
                lw=1.2, label=name)  # fmt: skip
    legend_below(fig, ax)
    # the polar radial axis replaces its formatter when drawn (plain_ticks' settings are lost):
    # a formatter of its own, plain from the start
    radial = ScalarFormatter(useOffset=False)
    radial.set_scientific(False)
    ax.yaxis.set_major_formatter(radial)
    ax.set_title(title or axis_label("Radial deviation", unit))
    return fig
