"""Figures of a machine over time: repeatability in a sliding window, hysteresis of the
probing approach and the control chart of a monitored quantity."""

from __future__ import annotations

from datetime import UTC, timedelta

import numpy as np
from matplotlib.figure import Figure

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

__all__ = [
    "control_chart",
    "hysteresis_bars",
    "window_repeatability",
]


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
    fig = new_figure(3.2 * len(names) + 0.6, 3.2)
    axes = fig.subplots(1, len(names), sharey=True, squeeze=False)[0]
    for ax, name in zip(axes, names, strict=True):
        by_start: dict[int, list[float]] = {}
        for starts, std in series[name]:
            ax.plot(starts, std, color=GREY, lw=0.6, alpha=0.6)
            for k, v in zip(starts, std, strict=True):
                by_start.setdefault(int(k), []).append(float(v))
        grid = sorted(by_start)
        ax.plot(grid, [np.median(by_start[k]) for k in grid], color=BLUE, lw=2, label="median")
        ax.set_xlabel("window start (iteration)")
        ax.set_ylabel(axis_label(name, unit))
        ax.grid(True, alpha=0.3)
    legend_below(fig, axes[0])
    fig.suptitle(title or f"Repeatability in a {window}-touch sliding window", fontsize=10)
    return plain_ticks(fig)


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
    fig = new_figure(6.4, 3.2)
    ax = fig.add_subplot()
    width = 0.6 * float(np.min(np.diff(psi))) if psi.size > 1 else 10.0
    ax.bar(psi, h, width=width, color=BLUE, alpha=0.8)
    ax.errorbar(psi, h, yerr=half, fmt="none", ecolor="black", elinewidth=1, capsize=3)
    ax.axhline(0.0, color="black", lw=0.6)
    ax.set_xlabel("ψ (deg)")
    ax.set_ylabel(axis_label("hysteresis error H", unit))
    ax.grid(True, axis="y", alpha=0.3)
    ax.set_title(title or "Hysteresis error per indexation, bars ±U")
    return plain_ticks(fig)


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
    fig = new_figure(7.2, 3.8)
    ax = fig.add_subplot()
    flags = np.asarray(out_of_control, dtype=bool)
    values = np.asarray(values, dtype=float)
    dates = _utc_datetime64(dates)
    ax.plot(dates, values, "o-", color=BLUE, ms=3, lw=0.8, label=name)
    ax.plot(dates[flags], values[flags], "o", color=RED, ms=6, label="out of control")
    ax.axhline(centre, color=GREY, lw=1, label="centre")
    for limit in limits:
        ax.axhline(limit, color=ORANGE, lw=1, ls="--")
    if prediction is not None:
        when, mean, half = prediction
        when = _utc_datetime64(when)
        ax.plot(when, mean, color=GREEN, lw=1, label="prediction")
        ax.fill_between(when, mean - half, mean + half, color=GREEN, alpha=0.2, lw=0)
    if mpe is not None:
        for bound in (-mpe, mpe):
            ax.axhline(bound, color=RED, lw=1)
    if due_date is not None:
        ax.axvline(
            np.datetime64(due_date.replace(tzinfo=None), "s"), color=RED, ls=":", label="due"
        )
    ax.set_ylabel(axis_label(name, unit))
    ax.set_title(f"{name} over time: individuals control chart (ISO 7870-2)")
    legend_below(fig, ax)
    return plain_ticks(fig)


def trend_chart(result, drifted=None) -> Figure:
    """The individuals chart of a parameter's history with, when ``drifted`` is given, the
    drift model's prediction ± 2 standard deviations up to the due date (or half the
    history's span ahead), the ±MPE lines and the due date: what ``mtm history trend
    --report`` and the web application's machine page draw.

    Parameters
    ----------
    result : TrendResult
        :func:`mtmetrology.history.parameter_trend`'s result (dates, values, centre, limits,
        out-of-control flags, parameter name and unit).
    drifted : DriftResult, optional
        :func:`mtmetrology.history.parameter_drift`'s result.

    Returns
    -------
    Figure
    """
    prediction = due = mpe = None
    if drifted is not None:
        span = (result.dates[-1] - result.dates[0]) / 2
        end = drifted.due_date if drifted.due_date is not None else drifted.last_date + span
        step = max((end - drifted.last_date) / 60, timedelta(days=1))
        ahead = [drifted.last_date + k * step for k in range(61)]
        mean, std = drifted.predict(ahead)
        prediction = (ahead, mean, 2 * std)
        due, mpe = drifted.due_date, drifted.mpe
    return control_chart(
        result.dates,
        result.values,
        result.centre,
        (result.lower_limit, result.upper_limit),
        result.out_of_control,
        name=result.parameter,
        unit=result.unit,
        prediction=prediction,
        mpe=mpe,
        due_date=due,
    )
