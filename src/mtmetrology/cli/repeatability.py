"""``mtm repeatability``: probing repeatability models from replicated on-machine probing.

``mtm repeatability fit RECORDS.csv -o R.json`` computes, per target pose, the standard
deviations and covariances of the readings (first touch discarded) and fits the
standard-deviation (Sepahi Boroujeni (2021), eq. 4-1) and covariance (eq. 4-2) models on
normalised pose factors; ``R.json`` is a ``repeatability-model`` document.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from mtmetrology.cli._common import (
    ReportOption,
    command_line,
    print_json,
    user_errors,
    write_report,
)
from mtmetrology.errors import InputError
from mtmetrology.io import read_csv_table, write_json
from mtmetrology.omm.repeatability import (
    COVARIANCE_OUTPUTS,
    STD_OUTPUTS,
    factors_from_file_units,
    fit_repeatability_model,
    target_statistics,
)

app = typer.Typer(
    help="Probing repeatability models (on-machine measurement).", no_args_is_help=True
)

RECORD_COLUMNS = ("target", "phi", "theta", "B", "C", "X_T", "Y_T", "Z_T", "i", "j", "k")
READING_COLUMNS = ("X", "Y", "Z", "time")
CENTRE_COLUMNS = ("centre_X", "centre_Y", "centre_Z")


@app.callback()
def _group() -> None:
    """Probing repeatability models (on-machine measurement)."""


def _read_records(path: Path) -> dict:
    table = read_csv_table(path, required=RECORD_COLUMNS + READING_COLUMNS)
    factors = factors_from_file_units(
        *(table.floats(c) for c in ("phi", "theta", "B", "C", "X_T", "Y_T", "Z_T"))
    )
    approach = np.column_stack([table.floats(c) for c in "ijk"])
    length = np.linalg.norm(approach, axis=1)
    if np.any(length == 0):
        line = table.lines[int(np.flatnonzero(length == 0)[0])]
        raise InputError(f"{path}, line {line}: the approach (i, j, k) is the zero vector")
    centre = None
    if any(table.has(c) for c in CENTRE_COLUMNS):
        centre = np.column_stack([table.floats(c) for c in CENTRE_COLUMNS])
    return dict(
        target=table.strings("target"),
        factors=factors,
        readings=np.column_stack([table.floats(c) for c in "XYZ"]),
        normal=-approach / length[:, None],  # the probe approaches along −n̂
        time=table.floats("time"),
        centre=centre,
        where=str(path),
    )


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
      centre_X, centre_Y, centre_Z   optional sphere centre for the N/T projections (mm)

    The first touch of every target is discarded (hysteresis of the preceding motion).
    Per target: σ of X, Y, Z and of the normal/tangential projections N, T, and
    cov(X,Y), cov(X,Z), cov(Y,Z), cov(N,T). The models need more than 36 fitting targets
    and at least six distinct values of each factor. Output units: µm, µm².
    """
    data = _read_records(records)
    stats = target_statistics(**data)
    model = fit_repeatability_model(stats, holdout=holdout, seed=seed)
    document = model.to_dict()
    document["source"] = str(records)
    document["statistics"] = stats.to_dict()
    zero = [t for t, z in zip(stats.targets, stats.zero_variance, strict=True) if z.any()]
    document["resolution_warnings"] = zero
    json.dumps(document, allow_nan=False)  # refuse NaN before anything is written
    if report_path is not None:
        report = _report(ctx, records, document)
    write_json(output, document)
    typer.echo(f"repeatability model written to {output}", err=True)
    if report_path is not None:
        write_report(report, report_path)
    if json_output:
        print_json(document)
    elif zero:
        typer.echo(
            f"warning: zero variance of a coordinate at {len(zero)} target(s) "
            f"({', '.join(zero[:5])}): approach slightly off the axes",
            err=True,
        )


def _report(ctx: typer.Context, records: Path, document: dict):
    from mtmetrology.report import Report

    rep = Report(
        f"Probing repeatability: {records.name}",
        command=command_line(ctx),
        provenance={"inputs": [records]},
    )
    rep.section(
        "Models",
        f"{document['n_fit']} targets fitted, {document['n_validation']} held out. "
        "Separable polynomials on normalised factors (Sepahi Boroujeni (2021), "
        "eqs. 4-1 and 4-2).",
    )
    rows = []
    for o in document["outputs"]:
        rel = o["validation_max_relative_error"]
        rows.append(
            [
                o["name"],
                o["unit"],
                len(o["coefficients"]),
                f"{100 * o['r_squared']:.1f} %",
                "—" if rel is None else f"{100 * rel:.1f} %",
                "—"
                if o["validation_max_abs_error"] is None
                else f"{o['validation_max_abs_error']:.3f}",
            ]
        )
    rep.table(
        ["output", "unit", "coefficients", "R²", "max validation error", "max abs. difference"],
        rows,
    )
    rep.section("Per-target statistics")
    names = STD_OUTPUTS + COVARIANCE_OUTPUTS
    rep.table(
        ["target", "touches", *names],
        [
            [t["target"], t["n_touches"], *(f"{t[n]:.3f}" for n in names)]
            for t in document["statistics"]["targets"]
        ],
        caption="σ in µm, covariances in µm²; first touch discarded.",
    )
    return rep
