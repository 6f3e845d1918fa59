"""``mtm export``: compensation tables for a control, the residual they leave, and the check
of the tables on the machine.

One subcommand per format (``mtm export linuxcnc …``), all made from :data:`FORMATS` and the
one function :func:`export_format` (one options declaration, one body: the format is the
name the command was called by); ``mtm export check`` compares the readings taken with the
verification programme with the prediction.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from typer.core import TyperGroup

from mtmetrology.cli._common import (
    MachineOption,
    ReportOption,
    command_line,
    emit_result,
    fail,
    readings_from_table,
    senses_from_table,
    user_errors,
)
from mtmetrology.errors import EXIT_NOT_CONFIRMED, InputError

if TYPE_CHECKING:
    from mtmetrology.export.tabulated import MeasuredTable
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.parameter_set import ParameterSet
    from mtmetrology.kinematics.volumetric_map import VolumetricMap

_PITCH = (
    "Exactly one of --pitch and --points is required. --verify-program also writes the "
    "check programme and verify_readings.csv (then: mtm export check)."
)
#: Per format: its help (files written, what it carries), and the options that apply to
#: it besides the common ones (the others are hidden from its help and refused).
FORMATS = {
    "linuxcnc": (
        "LinuxCNC joint compensation tables.\n\n"
        "Writes x.comp, y.comp ... (one per tabulated joint, lines 'nominal forward reverse' "
        "in mm or deg, no header line: LinuxCNC's loader stops at the first line that is not "
        "three numbers) and compensation.ini (the [JOINT_n] COMP_FILE and COMP_FILE_TYPE = 1 "
        "lines to paste), with check.json. Carries the positioning error of each joint's own "
        "axis (E_XX, E_YY, E_ZZ, E_AA, E_BB, E_CC), per direction when the model has a "
        "reversal term; at most 256 lines per joint.",
        {"axes", "functions", "bound"},
    ),
    "fanuc": (
        "FANUC pitch-error compensation parameters.\n\n"
        "Writes fanuc_pitch.txt (parameters 3620-3627 per axis and the increments "
        "N10000+n), with check.json. Carries the positioning error of each axis (E_XX ...), "
        "in both directions when the model has a reversal term; at most 1024 points over all "
        "axes. --reference sets the reference position of an axis, where its table is zero.",
        {"axes", "functions", "bound", "reference"},
    ),
    "siemens": (
        "SINUMERIK interpolatory compensation tables.\n\n"
        "Writes ENC_COMP.INI ($AA_ENC_COMP: positioning errors E_XX ...) and CEC.INI "
        "($AN_CEC: straightness, e.g. E_YX with input axis X and output axis Y; per direction "
        "when the model has a reversal term), with check.json. Angular error functions are "
        "not carried. At most 200 points per table (MD38000 / MD18342 default). Axes are "
        "named by their machine-axis names, X1, Y1, Z1 ... as in K3's examples; "
        "--axis-names maps them (e.g. X=AX1,Y=AX2). The tables hold the errors +E: 'A "
        "positive compensation value causes the corresponding machine axis to move in the "
        "negative direction' (K3, 6FC5397-1BP40-3BA1, p. 238); the sign of $AN_CEC is not "
        "stated by K3 and is flagged.",
        {"axes", "functions", "bound", "axis_names"},
    ),
    "isg": (
        "ISG kernel volumetric compensation (VolComp, ISG_CSV format).\n\n"
        "Writes volcomp.csv (every error function per axis and the location errors) and "
        "volcomp.lis (its configuration), and a bilateral leadscrew list ssfk_x.lis ... for an "
        "own-axis function with a reversal term, with check.json. Carries every error "
        "function and location error.",
        {"axes", "functions", "bound"},
    ),
    "etalon": (
        "ISG kernel volumetric compensation in the Etalon exchange format.\n\n"
        "Writes volcomp.exc and volcomp.lis (file_format ETALON_EXCHANGE), and ssfk_x.lis ... "
        "as the isg format, with check.json. Carries every error function and location error.",
        {"axes", "functions", "bound"},
    ),
    "grid": (
        "Volumetric grid of errors of indication at nominal tool points.\n\n"
        "Writes volumetric_grid.csv (x, y, z in mm; ex, ey, ez in µm, e = P_indicated - "
        "P_true: the control commands P + e(P); ux, uy, uz when known), with check.json. "
        "Linear axes X, Y, Z only. RESULT may also be a volumetric-map document or a vendor "
        "grid CSV, resampled on the grid; --region restricts the grid to a box.",
        {"region"},
    ),
}
#: Options that apply to some formats only (the parameter names of :func:`export_format`).
_SPECIFIC = {
    "axes": "--axes",
    "functions": "--functions",
    "bound": "--bound",
    "reference": "--reference",
    "region": "--region",
    "axis_names": "--axis-names",
}
_HEIDENHAIN = (
    "Heidenhain is not written: the syntax of its compensation tables and the sign of their "
    "values could not be cited from Heidenhain's documentation, and a sign error doubles the "
    "machine's error."
)


class ExportGroup(TyperGroup):
    """The ``export`` group: a format's inapplicable options are hidden from its help, and
    an unknown format is refused naming the formats (exit 2)."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        for name, (_, applies) in FORMATS.items():
            command = self.commands.get(name)
            for param in [] if command is None else command.params:
                if param.name in _SPECIFIC and param.name not in applies:
                    param.hidden = True

    def resolve_command(self, ctx, args):
        if args and not args[0].startswith("-") and args[0] not in self.commands:
            raise InputError(
                f"format: {args[0]!r} is not one of {', '.join(FORMATS)} (or check); " + _HEIDENHAIN
            )
        return super().resolve_command(ctx, args)


app = typer.Typer(
    cls=ExportGroup,
    no_args_is_help=True,
    help=(
        "Write a control's compensation tables and check.json: the residual tool-point error "
        "after the control's own interpolation, with its uncertainty (k = 2), on a grid over "
        "the travel.\n\n"
        "One command per format: mtm export FORMAT RESULT --machine M (--pitch P | --points N) "
        "-o DIR; mtm export FORMAT --help says what it writes and carries. The directory is "
        "created if absent; it holds one export's files, listed in mtm-export-manifest.json: "
        "a previous export's files are replaced with --force, and a directory holding any "
        "other file is refused.\n\n"
        "Confirm a table's sign and size on the machine before relying on it: --verify-program "
        "writes a check programme and verify_readings.csv; mtm export check compares the "
        "readings taken with the prediction.\n\n" + _HEIDENHAIN
    ),
)


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


def _axis_names(text: str | None) -> dict | None:
    """``X=X1,Y=AX2`` -> {"X": "X1", "Y": "AX2"} (the library checks the names)."""
    if not text:
        return None
    out = {}
    for item in _split(text):
        axis, sep, name = item.partition("=")
        if not sep or not axis.strip() or not name.strip():
            fail(f"--axis-names: {item!r} is not AXIS=NAME")
        out[axis.strip().upper()] = name.strip()
    return out


def _source(
    path: Path, machine: Machine, fmt: str, measured: str | None = None
) -> ParameterSet | VolumetricMap | MeasuredTable:
    """The parameter set, or for the grid format also a volumetric map: a map document
    (kind volumetric-map) or a vendor grid CSV (x,y,z,ex,ey,ez[,ux,uy,uz]; errors); with
    ``measured`` the pitch table of a laser result (per direction or the mean)."""
    from mtmetrology.export.tabulated import MeasuredTable
    from mtmetrology.io import load_document
    from mtmetrology.kinematics.parameter_set import ParameterSet
    from mtmetrology.kinematics.volumetric_map import MAP_KIND, VolumetricMap

    if measured is not None:
        if measured not in ("bidirectional", "mean"):
            fail(f"--measured: {measured!r} is not bidirectional or mean")
        doc = load_document(path, "laser result")
        return MeasuredTable.from_result(
            doc, str(path), bidirectional=measured == "bidirectional", machine=machine.name
        )
    if fmt == "grid" and path.suffix.lower() == ".csv":
        return VolumetricMap.from_table(path, machine=machine.name)
    doc = load_document(path, "parameter set or map")
    if isinstance(doc, dict) and doc.get("kind") == MAP_KIND:
        return VolumetricMap.from_dict(doc, str(path))
    return ParameterSet.from_document(doc, machine, str(path))


@user_errors
def export_format(
    ctx: typer.Context,
    params: Annotated[
        Path,
        typer.Argument(
            metavar="RESULT",
            help="Parameter set or calibration result JSON; grid: also a volumetric-map "
            "document or a vendor grid CSV x,y,z,ex,ey,ez[,ux,uy,uz] (mm, µm; errors).",
        ),
    ],
    machine: MachineOption,
    output: Annotated[
        Path,
        typer.Option(
            "-o", "--output", help="Output directory: absent, empty, or a previous export's."
        ),
    ],
    pitch: Annotated[
        float | None, typer.Option("--pitch", help="Table spacing: mm (linear), deg (rotary).")
    ] = None,
    points: Annotated[
        int | None, typer.Option("--points", help="Points per table over the travel.")
    ] = None,
    force: Annotated[
        bool, typer.Option("--force", help="Replace the files of a previous export in -o.")
    ] = False,
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
            "--region", help="Box of tool-point positions, e.g. x=800:1000,z=100:300 (mm)."
        ),
    ] = None,
    reference: Annotated[
        str | None,
        typer.Option("--reference", help="Reference position per axis, e.g. X=0,Y=0."),
    ] = None,
    axis_names: Annotated[
        str | None,
        typer.Option("--axis-names", help="Control's machine-axis names, e.g. X=X1,Y=AX2."),
    ] = None,
    at: Annotated[
        Path | None,
        typer.Option(
            "--at", help="Readings CSV (X,Y,Z[,B,C]; mm, deg; sense_<axis> ±1): residual there."
        ),
    ] = None,
    verify_program: Annotated[
        bool,
        typer.Option(
            "--verify-program", help="Also write the check programme and verify_readings.csv."
        ),
    ] = False,
    verify_positions: Annotated[
        int, typer.Option("--verify-positions", help="Check positions per linear axis.")
    ] = 5,
    verify_overrun: Annotated[
        float, typer.Option("--verify-overrun", help="Overrun before each approach, mm.")
    ] = 5.0,
    measured: Annotated[
        str | None,
        typer.Option(
            "--measured",
            help="Laser result (mtm laser analyse): tabulate its measured pitch table point by "
            "point, per direction (bidirectional) or the mean of both (mean), not the fitted "
            "E_XX.",
        ),
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the check JSON.")] = False,
    report_path: ReportOption = None,
) -> None:
    """Every format's command: the format is the name it was called by (its help is the
    format's, :data:`FORMATS`)."""
    from mtmetrology.export.manifest import MANIFEST, commit_output, plan_output
    from mtmetrology.export.verification import DIALECTS, TEMPLATE, export_with_verification
    from mtmetrology.io import read_csv_table, write_columns
    from mtmetrology.io.files import atomic_write, check_output
    from mtmetrology.kinematics.machine import Machine

    fmt = ctx.info_name
    applies = FORMATS[fmt][1]
    given = {"axes": axes, "functions": functions, "bound": bound}
    given |= {"reference": reference, "region": region, "axis_names": axis_names}
    for name, value in given.items():
        if value is not None and name not in applies:
            fail(f"{_SPECIFIC[name]}: does not apply to the {fmt} format")
    if (pitch is None) == (points is None):
        fail("give exactly one of --pitch and --points")
    if check_per_axis < 2:
        fail(f"--check-per-axis: {check_per_axis} < 2")
    inputs = [params] + ([at] if at is not None else [])
    inside = report_path is not None and report_path.resolve().parent == output.resolve()
    if report_path is not None and (output.is_dir() or not inside):
        check_output(report_path, inputs)
    plan_output(output, (), force=force)  # refused before the work; again with the names
    m = Machine.load(machine)
    pset = _source(params, m, fmt, measured)
    readings = senses = None
    if at is not None:
        table = read_csv_table(at)
        readings, senses = readings_from_table(m, table), senses_from_table(m, table)
    result, verify_files = export_with_verification(
        m,
        pset,
        fmt,
        verify_positions=verify_positions if verify_program else None,
        verify_overrun_mm=verify_overrun,
        at=readings,
        at_senses=senses,
        axes=_split(axes),
        pitch=pitch,
        points=points,
        functions=_split(functions),
        check_per_axis=check_per_axis,
        bound_um=bound,
        region=_per_axis(region, "--region", pair=True),
        reference=_per_axis(reference, "--reference", pair=False),
        axis_names=_axis_names(axis_names),
    )
    names = [*result.files, *verify_files, "check.json"]
    names += ["residual_at.csv"] if at is not None else []
    if inside:
        names.append(report_path.name)  # a report inside the directory is this run's file
    plan = plan_output(output, names, force=force)
    if not plan.create:
        for name in names:
            check_output(output / name, inputs)
    doc = result.to_dict()
    report = None
    if report_path is not None:
        import mtmetrology.export.report  # noqa: F401  (registers the renderer)
        from mtmetrology.report import Report
        from mtmetrology.report.results import add_result

        report = Report(
            f"Compensation tables: {result.format}",
            command=command_line(ctx),
            provenance={"inputs": inputs},
        )
        add_result(report, result)
    commit_output(plan, fmt, command_line(ctx))
    for name, text in {**result.files, **verify_files}.items():
        with atomic_write(output / name) as fh:
            fh.write(text)
    if at is not None:
        r, big_u = result.at_points["r"], result.at_points["U"]
        columns = {f"r{c}_um": r[:, k] for k, c in enumerate("xyz")}
        if big_u is not None:
            columns.update({f"U{c}_um": big_u[:, k] for k, c in enumerate("xyz")})
        with atomic_write(output / "residual_at.csv", "wb") as fh:
            write_columns(fh, columns, decimals=4)

    def summary() -> None:
        r = result.residual
        typer.echo(f"{result.format}: wrote {', '.join(names)} to {output} ({MANIFEST})")
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
        if r.get("interpolation_bound_um") is not None:
            typer.echo(
                f"measured pitch table: interpolation bound {r['interpolation_bound_um']:.3g} µm "
                "at this pitch (the largest residual the sampling leaves over the axis)"
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
        if verify_files:
            typer.echo(
                f"verification: run {DIALECTS[fmt].file} on the machine with the tables loaded, "
                f"fill {TEMPLATE}, then: mtm export check {output / TEMPLATE}"
            )

    emit_result(
        doc,
        summary,
        output=output / "check.json",
        report=report,
        report_path=report_path,
        as_json=as_json,
    )


for _name, (_help, _) in FORMATS.items():
    app.command(_name, help=f"{_help}\n\n{_PITCH}")(export_format)


@app.command("check")
@user_errors
def check(
    readings: Annotated[
        Path,
        typer.Argument(metavar="READINGS", help="verify_readings.csv with the readings filled in."),
    ],
    u_reading: Annotated[
        float | None,
        typer.Option(
            "--u-reading",
            help="Standard uncertainty of a reading, µm (where u_reading_um is empty).",
        ),
    ] = None,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Write the result JSON here.")
    ] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print the result JSON.")] = False,
) -> None:
    """Compare the readings taken with the verification programme with the prediction:
    is the table's sign and size confirmed?

    A measured deviation m (actual - target, µm; a laser along the line's axis gives that
    axis's component only) is confirmed when |m - r| <= U_c, r the predicted residual and
    U_c = 2 sqrt((U/2)^2 + u_reading^2) (k = 2). Over the points where the table corrects
    more than 2 U_c, the multiple of the table the control applies is estimated: 1 confirmed,
    -1 sign error (the residual is about twice the error), 0 table not active, else size not
    confirmed.

    Exit code 0 when confirmed, 4 otherwise (the verdict is in the output).
    """
    from mtmetrology.export.verification_check import compare_readings
    from mtmetrology.io.files import check_output

    if output is not None:
        check_output(output, [readings])
    result = compare_readings(readings, u_reading)
    doc = result.to_dict()

    def summary() -> None:
        k = (
            ""
            if result.factor is None
            else (
                f"; the control applies {result.factor:.3f} × the table (u = {result.factor_u:.2g})"
            )
        )
        typer.echo(f"{readings.name}: {result.verdict}{k}")
        for p in result.points:
            if p["verdict"] != "confirmed":
                worst = max(p["components"], key=lambda c: abs(c["measured_um"] - c["r_um"]))
                typer.echo(
                    f"  {p['point']}: {p['verdict']}: {worst['component']} measured "
                    f"{worst['measured_um']:.3g} µm, predicted {worst['r_um']:.3g} ± "
                    f"{worst['U_c_um']:.2g} µm (k = 2), uncompensated {worst['e_um']:.3g} µm"
                )
        counts = ", ".join(f"{v} {k}" for k, v in doc["counts"].items())
        typer.echo(f"points: {counts}; chi2 {result.chi2:.3g} (99 % limit {result.chi2_limit:.3g})")
        for note in result.notes:
            typer.echo(f"note: {note}")

    emit_result(doc, summary, output=output, report=None, report_path=None, as_json=as_json)
    if not result.confirmed:
        raise typer.Exit(code=EXIT_NOT_CONFIRMED)
