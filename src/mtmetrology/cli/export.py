"""``mtm export``: compensation tables for a control, and the residual they leave."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from mtmetrology.cli._common import (
    MachineOption,
    ReportOption,
    command_line,
    emit_result,
    fail,
    readings_from_table,
    user_errors,
)
from mtmetrology.io.files import atomic_write, check_output

if TYPE_CHECKING:
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.parameter_set import ParameterSet
    from mtmetrology.kinematics.volumetric_map import VolumetricMap


def _split(text: str | None) -> list[str] | None:
    return [s.strip() for s in text.split(",") if s.strip()] if text else None


def _per_axis(text: str | None, option: str, pair: bool) -> dict | None:
    """``X=800:1000,Z=200:300`` -> {"X": (800.0, 1000.0), ...}; ``X=0,Y=0`` -> {"X": 0.0}."""
    if not text:
        return None
    out = {}
    for item in _split(text):
        try:
            axis, value = item.split("=")
            numbers = tuple(float(v) for v in value.split(":"))
            if len(numbers) != (2 if pair else 1):
                raise ValueError
        except ValueError:
            fail(f"{option}: {item!r} is not AXIS={'low:high' if pair else 'value'}")
        out[axis.strip().upper()] = numbers if pair else numbers[0]
    return out


def _source(path: Path, machine: Machine, fmt: str) -> ParameterSet | VolumetricMap:
    """The parameter set, or for the grid format also a volumetric map: a map document
    (kind volumetric-map) or a vendor grid CSV (x,y,z,ex,ey,ez[,ux,uy,uz]; errors)."""
    from mtmetrology.io import load_document
    from mtmetrology.kinematics.parameter_set import ParameterSet
    from mtmetrology.kinematics.volumetric_map import MAP_KIND, VolumetricMap

    if fmt == "grid" and path.suffix.lower() == ".csv":
        return VolumetricMap.from_table(path, machine=machine.name)
    doc = load_document(path, "parameter set or map")
    if isinstance(doc, dict) and doc.get("kind") == MAP_KIND:
        return VolumetricMap.from_dict(doc, str(path))
    return ParameterSet.from_document(doc, machine, str(path))


@user_errors
def export(
    ctx: typer.Context,
    fmt: Annotated[
        str, typer.Argument(metavar="FORMAT", help="linuxcnc, fanuc, siemens, isg, etalon or grid.")
    ],
    params: Annotated[
        Path,
        typer.Argument(
            metavar="RESULT",
            help="Parameter set or calibration result JSON; grid: also a volumetric-map "
            "document or a vendor grid CSV x,y,z,ex,ey,ez[,ux,uy,uz] (mm, µm; errors).",
        ),
    ],
    machine: MachineOption,
    output: Annotated[Path, typer.Option("-o", "--output", help="Existing output directory.")],
    pitch: Annotated[
        float | None, typer.Option("--pitch", help="Table spacing: mm (linear), deg (rotary).")
    ] = None,
    points: Annotated[
        int | None, typer.Option("--points", help="Points per table over the travel.")
    ] = None,
    axes: Annotated[str | None, typer.Option("--axes", help="Axes to tabulate, e.g. X,Y.")] = None,
    functions: Annotated[
        str | None, typer.Option("--functions", help="Error functions, e.g. E_XX,E_YX.")
    ] = None,
    bound: Annotated[
        float | None,
        typer.Option("--bound", help="Pitch advisor: interpolation-error bound, µm."),
    ] = None,
    check_per_axis: Annotated[
        int, typer.Option("--check-per-axis", help="Residual check: grid points per axis.")
    ] = 5,
    region: Annotated[
        str | None,
        typer.Option(
            "--region", help="grid: box of tool-point positions, e.g. x=800:1000,z=100:300 (mm)."
        ),
    ] = None,
    reference: Annotated[
        str | None,
        typer.Option("--reference", help="Reference position per axis, e.g. X=0,Y=0 (fanuc)."),
    ] = None,
    at: Annotated[
        Path | None,
        typer.Option("--at", help="Readings CSV (X,Y,Z[,B,C]; mm, deg): residual there too."),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the check JSON.")] = False,
    report_path: ReportOption = None,
) -> None:
    """Write a control's compensation tables and check.json: the residual tool-point error
    after the control's own interpolation, with its uncertainty (k = 2), on a grid over the
    travel."""
    from mtmetrology.export.workflow import export_compensation
    from mtmetrology.io import read_csv_table, write_columns
    from mtmetrology.kinematics.machine import Machine

    if (pitch is None) == (points is None):
        fail("give exactly one of --pitch and --points")
    if report_path is not None:
        check_output(report_path, [params])
    if not output.is_dir():
        fail(f"{output}: not an existing directory (it is not created)")
    if check_per_axis < 2:
        fail(f"--check-per-axis: {check_per_axis} < 2")
    m = Machine.load(machine)
    pset = _source(params, m, fmt.lower())
    readings = None
    if at is not None:
        readings = readings_from_table(m, read_csv_table(at))
    result = export_compensation(
        m,
        pset,
        fmt.lower(),
        pitch=pitch,
        points=points,
        axes=_split(axes),
        functions=_split(functions),
        check_per_axis=check_per_axis,
        bound_um=bound,
        region=_per_axis(region, "--region", pair=True),
        reference=_per_axis(reference, "--reference", pair=False),
        at=readings,
    )
    names = [*result.files, "check.json"] + (["residual_at.csv"] if at is not None else [])
    targets = {name: output / name for name in names}
    for target in targets.values():
        check_output(target, [params] + ([at] if at is not None else []))
    for name, text in result.files.items():
        with atomic_write(targets[name]) as fh:
            fh.write(text)
    if at is not None:
        r, big_u = result.at_points["r"], result.at_points["U"]
        columns = {f"r{c}_um": r[:, k] for k, c in enumerate("xyz")}
        if big_u is not None:
            columns.update({f"U{c}_um": big_u[:, k] for k, c in enumerate("xyz")})
        with atomic_write(targets["residual_at.csv"], "wb") as fh:
            write_columns(fh, columns, decimals=4)
    doc = result.to_dict()
    report = None
    if report_path is not None:
        import mtmetrology.export.report  # noqa: F401  (registers the renderer)
        from mtmetrology.report import Report
        from mtmetrology.report.results import add_result

        inputs = [params] + ([at] if at is not None else [])
        report = Report(
            f"Compensation tables: {result.format}",
            command=command_line(ctx),
            provenance={"inputs": inputs},
        )
        add_result(report, result)

    def summary() -> None:
        r = result.residual
        typer.echo(f"{result.format}: wrote {', '.join(targets)} to {output}")
        for t in result.tables:
            typer.echo(
                f"  {t['function']}: {t['points']} points"
                + (f", pitch {t['pitch']:g} {t['pitch_unit']}" if "pitch" in t else "")
                + f", largest correction {t['max_correction']:.2f} {t['unit']}"
            )
        if result.not_carried:
            typer.echo(f"  not carried by {result.format}: {', '.join(result.not_carried)}")
        u = "" if r["max_U_um"] is None else f", U (k = 2) up to {r['max_U_um']:.2g} µm"
        typer.echo(
            f"residual over {r['points']} check points: largest {r['max_um']:.3g} µm, "
            f"rms {r['rms_um']:.3g} µm{u} "
            f"(uncompensated largest {r['uncompensated_max_um']:.3g} µm)"
        )
        neg = r.get("negative")
        if neg is not None:
            u = "" if neg["max_U_um"] is None else f", U (k = 2) up to {neg['max_U_um']:.2g} µm"
            typer.echo(
                f"  travel in the negative direction: largest {neg['max_um']:.3g} µm, "
                f"rms {neg['rms_um']:.3g} µm{u} "
                f"(uncompensated {neg['uncompensated_max_um']:.3g} µm)"
            )
        if result.advisor is not None:
            typer.echo(f"pitch advisor: {result.advisor['reason']}")
        for note in result.notes:
            typer.echo(f"note: {note}")
        if result.at_points is not None:
            doc_at = doc["at_points"]
            typer.echo(
                f"at the {doc_at['points']} points of {at.name}: largest {doc_at['max_um']:.3g} µm "
                f"(residual_at.csv, µm, U with k = 2)"
            )

    emit_result(
        doc,
        summary,
        output=targets["check.json"],
        report=report,
        report_path=report_path,
        as_json=as_json,
    )
