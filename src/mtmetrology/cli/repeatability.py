"""``mtm repeatability``: probing repeatability models from replicated on-machine probing.

``mtm repeatability fit RECORDS.csv -o R.json`` computes, per target pose, the standard
deviations and covariances of the readings (first touch discarded; optionally after
removing a cubic drift, and with sliding-window standard deviations) and fits the
standard-deviation (Sepahi Boroujeni (2021), eq. 4-1) and covariance (eq. 4-2) models on
normalised pose factors; ``R.json`` is a ``repeatability-model`` document.
``mtm repeatability hysteresis RECORDS.csv`` evaluates probing or axis hysteresis errors
of ring-gauge probing (eqs. 4-3 and 4-4).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Literal

import typer

from mtmetrology.cli._common import (
    ReportOption,
    command_line,
    emit_result,
    user_errors,
)
from mtmetrology.omm.choices import MIN_TARGETS_PER_COEFFICIENT

app = typer.Typer(
    help="Probing repeatability models (on-machine measurement).", no_args_is_help=True
)


@app.callback()
def _group() -> None:
    """Probing repeatability models (on-machine measurement)."""


@app.command("fit")
@user_errors
def fit(
    ctx: typer.Context,
    records: Annotated[Path, typer.Argument(help="Replicated probing records (CSV).")],
    output: Annotated[
        Path, typer.Option("-o", "--output", help="Write the repeatability-model JSON here.")
    ],
    holdout: Annotated[
        float,
        typer.Option(help="Fraction of the targets held out to report validation errors."),
    ] = 0.15,
    seed: Annotated[int, typer.Option(help="Seed of the held-out draw.")] = 0,
    allow_few_targets: Annotated[
        bool,
        typer.Option(
            "--allow-few-targets",
            help=f"Fit with fewer than {MIN_TARGETS_PER_COEFFICIENT:g} fitting targets per "
            "coefficient (36 for the covariance model); the held-out errors say what the "
            "model is worth.",
        ),
    ] = False,
    drift: Annotated[
        Literal["none", "cubic"],
        typer.Option(
            help="cubic: remove a cubic drift in time from each target's series first; "
            "σ and covariances then come from the residuals (n − 4 degrees of freedom)."
        ),
    ] = "none",
    window: Annotated[
        int | None,
        typer.Option(
            help="Also give σ of X, Y, Z, N in a window of this many touches sliding along "
            "each target's series (the thesis uses 10).",
            min=2,
        ),
    ] = None,
    window_from: Annotated[
        int,
        typer.Option(
            help="Iteration (1 = first touch of a target) where the first window starts "
            "(the thesis uses 26, after the drift has settled).",
            min=1,
        ),
    ] = 2,
    json_output: Annotated[
        bool, typer.Option("--json", help="Also print the document on standard output.")
    ] = False,
    report_path: ReportOption = None,
) -> None:
    """Fit probing-repeatability models (Sepahi Boroujeni (2021), eqs. 4-1 and 4-2).

    RECORDS.csv has one row per touch, with the columns:

    \b
      target          target id (touches of one pose share it)
      phi, theta      target normal: polar angle from Z, azimuth from Y (deg)
      B, C            rotary axis positions of the pose (deg)
      X_T, Y_T, Z_T   commanded target position (mm)
      i, j, k         approach direction (the probe moves along it; any length)
      X, Y, Z         recorded readings (mm)
      time            time of the touch (s): orders the touches of a target
      centre_X, centre_Y, centre_Z
                      optional sphere centre for the N/T projections (mm)

    The first touch of every target is discarded (hysteresis of the preceding motion).
    Per target: σ of X, Y, Z and of the normal/tangential projections N, T, and
    cov(X,Y), cov(X,Z), cov(Y,Z), cov(N,T). The models need more than 36 fitting targets
    and at least six distinct values of each factor. Output units: µm, µm².

    --drift cubic fits c0 + c1 t + c2 t² + c3 t³ to each of a target's series against
    the time column (Sepahi Boroujeni (2021), §4) and needs at least 6 touches after the
    first. --window W adds a "windows" block (σ per window start, µm) and, with --report,
    a figure of σ against the window start.
    """
    from mtmetrology.omm.repeatability_records import fit_repeatability_file

    result = fit_repeatability_file(
        records,
        holdout=holdout,
        seed=seed,
        allow_few_targets=allow_few_targets,
        drift=drift,
        window=window,
        window_from=window_from,
    )
    document = result.to_dict()
    zero = result.resolution_warnings
    report = None if report_path is None else _report(ctx, records, "Probing repeatability", result)

    def summary() -> None:
        _print_validation(document)
        if zero:
            typer.echo(
                f"warning: zero variance of a coordinate at {len(zero)} target(s) "
                f"({', '.join(zero[:5])}): approach slightly off the axes",
                err=True,
            )

    emit_result(
        document,
        summary,
        output=output,
        report=report,
        report_path=report_path,
        as_json=json_output,
        messages=_written(output, "repeatability model"),
    )


def _print_validation(document: dict) -> None:
    """Held-out errors of every output model; a warning names those above the threshold."""
    if not document["n_validation"]:
        typer.echo("no targets held out (--holdout 0): the models are not validated")
        return
    typer.echo(
        f"held-out errors on {document['n_validation']} targets "
        f"({document['n_fit']} fitted); rms relative = held-out RMS error / RMS of the values"
    )
    typer.echo(
        f"  {'output':<8} {'max abs':>10} {'unit':<4} {'max relative':>12} {'rms relative':>12}"
    )
    for o in document["outputs"]:
        rel = o["validation_max_relative_error"]
        rms = o["validation_rms_relative_error"]
        typer.echo(
            f"  {o['name']:<8} {o['validation_max_abs_error']:>10.3g} {o['unit']:<4} "
            f"{'—' if rel is None else f'{100 * rel:.0f} %':>12} "
            f"{'—' if rms is None else f'{100 * rms:.0f} %':>12}"
            + ("  flagged" if o["validation_flagged"] else "")
        )
    flagged = [o["name"] for o in document["outputs"] if o["validation_flagged"]]
    if flagged:
        typer.echo(
            f"warning: held-out rms relative error above "
            f"{100 * document['validation_warning']:g} % for {', '.join(flagged)}: "
            "these models do not predict held-out poses; probe more poses",
            err=True,
        )


def _written(output: Path | None, what: str):
    """The message saying that ``output`` was written (None without ``-o``)."""
    if output is None:
        return None
    return lambda: typer.echo(f"{what} written to {output}", err=True)


def _report(ctx: typer.Context, records: Path, title: str, result):
    """The report of ``result`` (:mod:`mtmetrology.omm.report`) under ``title``."""
    from mtmetrology.report import Report
    from mtmetrology.report.results import add_result

    rep = Report(
        f"{title}: {records.name}", command=command_line(ctx), provenance={"inputs": [records]}
    )
    return add_result(rep, result)


@app.command("hysteresis")
@user_errors
def hysteresis(
    ctx: typer.Context,
    records: Annotated[Path, typer.Argument(help="Ring-gauge probing records (CSV).")],
    output: Annotated[
        Path | None,
        typer.Option("-o", "--output", help="Write the hysteresis-result JSON here."),
    ] = None,
    p: Annotated[float, typer.Option("--p", help="Coverage probability.")] = 0.95,
    json_output: Annotated[
        bool, typer.Option("--json", help="Print the document on standard output.")
    ] = False,
    report_path: ReportOption = None,
) -> None:
    """Probing or axis hysteresis errors (Sepahi Boroujeni (2021), eqs. 4-3 and 4-4).

    RECORDS.csv has one row per touch of a ring gauge, with the columns:

    \b
      psi         indexation of the touch (deg)
      condition   direct / hysteresis (probing test: the previous touch was
                  the same point / the opposite wall) or + / - (axis test:
                  pre-movement along the + / - direction of the cross axis);
                  one test per file
      r           radial projection (mm), or instead
      X, Y        readings relative to the ring centre (mm): r = X cos ψ + Y sin ψ

    Per indexation: H = mean r (hysteresis) − mean r (direct), or mean r (+) − mean r
    (−), u(H) = √(s_H²/n_H + s²/n), and H ± k u(H) with k the t quantile for the
    Welch–Satterthwaite degrees of freedom. Summary: the mean of H over the indexations
    with u = √(Σu²)/m, the mean of |H| and the RMS of u(H). Output unit: µm.
    """
    from mtmetrology.formatting import format_uncertainty, format_value
    from mtmetrology.omm.hysteresis import summary_line
    from mtmetrology.omm.repeatability_records import hysteresis_from_file

    result = hysteresis_from_file(records, p=p)
    document = result.to_dict()
    json.dumps(document, allow_nan=False)  # refuse NaN before anything is written
    kind = result.kind
    report = None if report_path is None else _report(ctx, records, "Hysteresis", result)

    def summary() -> None:
        typer.echo(f"{kind} hysteresis, {document['definition']} (µm), p = {p:g}")
        typer.echo(f"{'psi (deg)':>10} {'H':>8} {'u':>7} {'U':>7} {'k':>6}")
        for row, o in zip(document["indexations"], document["outputs"], strict=True):
            value, u, big_u = format_value(o["value"], o["u"]), o["u"], o["U"]
            typer.echo(
                f"{row['psi']:>10g} {value:>8} {format_uncertainty(u):>7} "
                f"{format_uncertainty(big_u):>7} {o['k']:>6.2f}"
            )
        typer.echo(summary_line(document["summary"]))

    emit_result(
        document,
        summary,
        output=output,
        report=report,
        report_path=report_path,
        as_json=json_output,
        messages=_written(output, "hysteresis result"),
    )
