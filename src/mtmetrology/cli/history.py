"""``mtm history``: the calibration history database (issue 24).

Each command parses, calls one function of :mod:`mtmetrology.history`, prints and writes.
"""

from __future__ import annotations

import csv
import io
import math
from datetime import UTC, datetime
from pathlib import Path
from typing import Annotated

import typer

from mtmetrology.cli._common import (
    CoverageK,
    CoverageP,
    ReportOption,
    command_line,
    coverage_from_options,
    emit_result,
    user_errors,
)
from mtmetrology.errors import InputError
from mtmetrology.io.files import atomic_write, write_json

app = typer.Typer(
    help="Calibration history: record results, control charts, drift, long-term covariance."
    "\n\nThe database: --db FILE or URL, else $MTMETROLOGY_DB, else history.sqlite in the "
    "user's data directory. Dates are ISO 8601; a date without an offset is UTC "
    "(2026-03-01T08:30+01:00 is 07:30 UTC). Reading commands never change the database: "
    "an older schema is upgraded by add or by mtm history upgrade.",
    no_args_is_help=True,
)

Db = Annotated[
    str | None,
    typer.Option("--db", help="SQLite file or URL (postgresql://...) [$MTMETROLOGY_DB]."),
]
MachineName = Annotated[str | None, typer.Option("--machine", help="Machine name.")]
#: The older positional machine of covariance and export (hidden; --machine is the form).
OldMachine = Annotated[str | None, typer.Argument(hidden=True, show_default=False)]
Since = Annotated[
    str | None, typer.Option("--since", help="ISO 8601 date (UTC unless it has an offset).")
]
CATEGORIES = ("calibration", "task", "verification")


def _date(text: str | None, option: str) -> datetime | None:
    """An ISO 8601 date as an instant: with its offset, or UTC when it states none."""
    if text is None:
        return None
    try:
        moment = datetime.fromisoformat(text)
    except ValueError:
        raise InputError(
            f"{option} {text!r}: not an ISO 8601 date (2026-03-01, 2026-03-01T08:30 UTC, "
            "or 2026-03-01T08:30+01:00)"
        ) from None
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=UTC)


def _machine_argument(positional: str | None, option: str | None) -> str | None:
    """The machine of covariance/export: ``--machine`` (the form of every history
    command), or the older positional argument, kept for compatibility."""
    if positional is not None and option is not None and positional != option:
        raise InputError(f"machine {positional!r} and --machine {option!r}: give one")
    return option if option is not None else positional


def _mpe(mpe: float | None) -> float | None:
    if mpe is not None and not mpe > 0:
        raise InputError(f"--mpe {mpe:g}: a maximum permissible error is positive")
    return mpe


def _category(category: str) -> str:
    if category not in CATEGORIES:
        raise InputError(f"--category {category!r}: one of {', '.join(CATEGORIES)}")
    return category


def _one_machine(engine, machine: str | None) -> str:
    from mtmetrology.history.series import machine_names

    if machine is not None:
        return machine
    names = machine_names(engine)
    if len(names) != 1:
        raise InputError(
            f"the history holds {len(names)} machines ({', '.join(names) or 'none'}); "
            "give --machine"
        )
    return names[0]


#: Prior of the drift model's random-walk variance (mtmetrology.history.drift, PRIORS).
RwPrior = Annotated[
    str,
    typer.Option(
        "--rw-prior",
        help="Prior of the random-walk variance, which is marginalised: reference (no scale "
        "assumed; conservative with few runs) or half-cauchy (scale: u per interval).",
    ),
]


@app.command("add")
@user_errors
def add(
    results: Annotated[
        list[Path],
        typer.Argument(help="RESULT.json of a calibrate, task or verify command (one or more)."),
    ],
    machine: Annotated[
        str | None,
        typer.Option("--machine", help="Preset name or machine YAML [the machine the file names]."),
    ] = None,
    note: Annotated[str | None, typer.Option("--note", help="Operator note.")] = None,
    date: Annotated[
        str | None,
        typer.Option(
            "--date",
            help="When it was measured, ISO 8601; UTC unless an offset is given "
            "(2026-03-01T08:30+01:00) [now].",
        ),
    ] = None,
    artefact: Annotated[str | None, typer.Option("--artefact", help="Artefact used.")] = None,
    temperature: Annotated[
        float | None,
        typer.Option("--temperature", help="Workshop temperature, °C (-50 to 100)."),
    ] = None,
    serial: Annotated[str | None, typer.Option("--serial", help="Machine serial number.")] = None,
    inputs: Annotated[
        list[Path] | None, typer.Option("--input", help="Input file whose SHA-256 is kept.")
    ] = None,
    by: Annotated[str | None, typer.Option("--by", help="Who records [the login name].")] = None,
    db: Db = None,
    json: Annotated[bool, typer.Option("--json", help="Print the stored run(s).")] = False,
) -> None:
    """Record results in the history. Several files are one transaction: all are recorded,
    each with its audit row, or, if one is refused, none (the options apply to each)."""
    import getpass

    from mtmetrology.history.records import add_results, check_temperature
    from mtmetrology.io.documents import load_document
    from mtmetrology.kinematics.machine import Machine

    when = _date(date, "--date")
    check_temperature(temperature, "--temperature")
    machines: dict[str, Machine] = {}
    items = []
    for result in results:
        document = load_document(result, "result")
        name = machine
        if name is None:
            name = document.get("machine") if isinstance(document, dict) else None
            if not isinstance(name, str):
                raise InputError(
                    f"{result}: no machine field (not a result document of a machine); "
                    "give --machine"
                )
        if name not in machines:
            machines[name] = Machine.load(name)
        items.append(
            {
                "document": document,
                "machine": machines[name],
                "source": str(result),
                "performed_at": when,
                "note": note,
                "artefact": artefact,
                "temperature_c": temperature,
                "serial": serial,
                "input_files": tuple(inputs or ()),
            }
        )
    records = add_results(db, items, by=f"cli:{by or getpass.getuser()}")

    def summary() -> None:
        for record in records:
            typer.echo(
                f"recorded {record.category} run {record.id} of {record.machine} "
                f"({record.kind}, {record.performed_at.isoformat(timespec='minutes')})"
            )

    document = (
        records[0].to_dict()
        if len(records) == 1
        else {"kind": "history-runs", "version": 1, "runs": [r.to_dict() for r in records]}
    )
    emit_result(document, summary, output=None, report=None, report_path=None, as_json=json)


@app.command("upgrade")
@user_errors
def upgrade(db: Db = None) -> None:
    """Bring the database to this version's schema (what add does before writing)."""
    from mtmetrology.history.database import HEAD, open_history, schema_revision

    engine = open_history(db)
    typer.echo(f"database at schema revision {schema_revision(engine)} (current {HEAD})")


@app.command("list")
@user_errors
def list_(
    machine: Annotated[str | None, typer.Option("--machine", help="Only this machine.")] = None,
    category: Annotated[
        str, typer.Option("--category", help="calibration, task or verification.")
    ] = "calibration",
    since: Since = None,
    db: Db = None,
    json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """List the recorded runs, oldest first."""
    from mtmetrology.history.records import list_runs

    runs = list_runs(
        db,
        machine=machine,
        category=_category(category),
        since=_date(since, "--since"),
    )

    def summary() -> None:
        for r in runs:
            typer.echo(
                f"{r.id:>6}  {r.performed_at.isoformat(timespec='minutes')}  {r.machine:<24} "
                f"{r.kind:<22} "
                f"{r.operator_note or ''}"
            )
        typer.echo(f"{len(runs)} {category} run(s)", err=True)

    emit_result(
        {"kind": "history-list", "version": 1, "runs": [r.to_dict() for r in runs]},
        summary,
        output=None,
        report=None,
        report_path=None,
        as_json=json,
    )


@app.command("show")
@user_errors
def show(
    run: Annotated[int, typer.Argument(help="Run number (mtm history list).")],
    category: Annotated[
        str, typer.Option("--category", help="calibration, task or verification.")
    ] = "calibration",
    db: Db = None,
    json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Show one recorded run."""
    from mtmetrology.formatting import format_result
    from mtmetrology.history.amendments import show_amended

    record, amendments = show_amended(db, run, _category(category))
    document = {**record.to_dict(), "amendments": [a.to_dict() for a in amendments]}

    def summary() -> None:
        typer.echo(
            f"{record.category} run {record.id}: {record.machine}, {record.kind}, performed "
            f"{record.performed_at.isoformat()}, recorded {record.recorded_at.isoformat()} "
            f"(mtmetrology {record.software_version})"
        )
        for label, value in (
            ("note", record.operator_note),
            ("artefact", record.artefact),
            ("temperature", None if record.temperature_c is None else f"{record.temperature_c} °C"),
        ):
            if value is not None:
                typer.echo(f"  {label}: {value}")
        for key, value in record.residual_statistics.items():
            typer.echo(f"  {key}: {value}")
        for path, sha in record.input_hashes.items():
            typer.echo(f"  sha256 {sha}  {path}")
        for p in record.parameters:
            typer.echo("  " + format_result(p["value"], p["u"], p["unit"], name=p["name"]))
        for a in amendments:
            typer.echo(
                f"  amended {a.amended_at:%Y-%m-%d %H:%M} UTC by {a.amended_by}: {a.field} "
                f"{a.old_value!r} -> {a.new_value!r} ({a.reason})"
            )

    emit_result(document, summary, output=None, report=None, report_path=None, as_json=json)


@app.command("amend")
@user_errors
def amend(
    run: Annotated[int, typer.Argument(help="Run number (mtm history list).")],
    why: Annotated[str, typer.Option("--why", help="Why the record is corrected (kept).")],
    date: Annotated[
        str | None, typer.Option("--date", help="When it was measured (ISO 8601).")
    ] = None,
    note: Annotated[str | None, typer.Option("--note", help="Operator note.")] = None,
    temperature: Annotated[
        float | None, typer.Option("--temperature", help="Workshop temperature, °C.")
    ] = None,
    operator: Annotated[str | None, typer.Option("--operator", help="Who measured.")] = None,
    by: Annotated[str | None, typer.Option("--by", help="Who amends [the login name].")] = None,
    category: Annotated[
        str, typer.Option("--category", help="calibration, task or verification.")
    ] = "calibration",
    db: Db = None,
    json: Annotated[bool, typer.Option("--json", help="Print the amendments.")] = False,
) -> None:
    """Correct a run's date, note, temperature or operator: an audited amendment that keeps
    the original value (mtm history show lists them)."""
    import getpass

    from mtmetrology.history import open_history
    from mtmetrology.history.amendments import amend_run

    amendments = amend_run(
        open_history(db),
        run,
        {
            "performed_at": _date(date, "--date"),
            "operator_note": note,
            "temperature_c": temperature,
            "operator": operator,
        },
        reason=why,
        by=f"cli:{by or getpass.getuser()}",
        category=_category(category),
    )
    emit_result(
        {
            "kind": "history-amendments",
            "version": 1,
            "amendments": [a.to_dict() for a in amendments],
        },
        "\n".join(
            f"amended {category} run {run}: {a.field} {a.old_value!r} -> {a.new_value!r}"
            for a in amendments
        ),
        output=None,
        report=None,
        report_path=None,
        as_json=json,
    )


@app.command("trend")
@user_errors
def trend(
    ctx: typer.Context,
    parameter: Annotated[str, typer.Argument(help="Parameter name, e.g. E_X0C.")],
    machine: MachineName = None,
    since: Since = None,
    baseline: Annotated[
        int | None, typer.Option("--baseline", help="First runs that set the limits [all].")
    ] = None,
    mpe: Annotated[
        float | None,
        typer.Option("--mpe", help="Maximum permissible error: drift and due date on the plot."),
    ] = None,
    reliability: Annotated[
        float, typer.Option("--reliability", help="In-tolerance probability at the due date.")
    ] = 0.95,
    rw_prior: RwPrior = "reference",
    db: Db = None,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="TREND.json.")] = None,
    report_path: ReportOption = None,
    json: Annotated[bool, typer.Option("--json", help="Print TREND.json.")] = False,
    k: CoverageK = None,
    p: CoverageP = None,
) -> None:
    """Individuals control chart of a parameter (Shewhart limits x̄ ± 3 MR̄/1.128)."""
    from mtmetrology.history import open_history, parameter_drift, parameter_trend

    mpe = _mpe(mpe)
    policy = coverage_from_options(k, p)
    when = _date(since, "--since")
    engine = open_history(db, read_only=True)
    name = _one_machine(engine, machine)
    result = parameter_trend(engine, name, parameter, since=when, baseline=baseline)
    drifted = None
    if mpe is not None:
        drifted = parameter_drift(
            engine,
            name,
            parameter,
            mpe=mpe,
            reliability=reliability,
            since=when,
            prior=rw_prior,
            coverage_probability=policy.p,
        )
    document = result.to_dict()
    if drifted is not None:
        document["drift"] = drifted.to_dict()
    report = None if report_path is None else _trend_report(ctx, result, drifted)

    def summary() -> None:
        typer.echo(
            f"{result.parameter} of {result.machine}: {len(result.values)} runs, centre "
            f"{result.centre:.4f} {result.unit}, limits [{result.lower_limit:.4f}, "
            f"{result.upper_limit:.4f}] {result.unit} (sigma {result.sigma:.2g} from "
            f"{result.baseline} runs)"
        )
        for i, d, v, flag in zip(
            result.run_ids, result.dates, result.values, result.out_of_control, strict=True
        ):
            if flag:
                typer.echo(f"  out of control: run {i} ({d:%Y-%m-%d}) {v:.4f} {result.unit}")
        typer.echo(f"{int(result.out_of_control.sum())} point(s) out of control")
        hint = result.hint()
        if hint is not None:
            typer.echo(f"hint: {hint['reason']}; see: {hint['command']}")

    emit_result(
        document, summary, output=output, report=report, report_path=report_path, as_json=json
    )


def _trend_report(ctx: typer.Context, result, drifted):
    from mtmetrology.formatting import format_result
    from mtmetrology.report import Report
    from mtmetrology.report.figures.monitoring import trend_chart

    report = Report(
        f"Control chart of {result.parameter}, {result.machine}", command=command_line(ctx)
    )
    report.section(
        "Control chart",
        f"Individuals chart (ISO 7870-2): centre {result.centre:.4f} {result.unit}, control "
        f"limits x̄ ± 3 MR̄/1.128 = [{result.lower_limit:.4f}, {result.upper_limit:.4f}] "
        f"{result.unit} from the first {result.baseline} runs; "
        f"{int(result.out_of_control.sum())} point(s) out of control.",
    )
    if drifted is not None:
        due, mpe = drifted.due_date, drifted.mpe
        slope = format_result(
            drifted.slope * 365.25, drifted.u_slope * 365.25, f"{result.unit}/year", name="slope"
        )
        report.text(
            f"Drift: {slope}; the band is the prediction ± 2 standard deviations; due "
            f"{'beyond the horizon' if due is None else f'{due:%Y-%m-%d}'} (P(|x| > "
            f"{mpe:g} {result.unit}) passes {1 - drifted.reliability:.3g})."
        )
    report.figure(trend_chart(result, drifted))
    report.table(
        ["run", "date", f"{result.parameter} ({result.unit})", "out of control"],
        [
            [str(i), f"{d:%Y-%m-%d %H:%M}", float(v), "yes" if flag else ""]
            for i, d, v, flag in zip(
                result.run_ids, result.dates, result.values, result.out_of_control, strict=True
            )
        ],
    )
    return report


@app.command("covariance")
@user_errors
def covariance(
    output: Annotated[Path, typer.Option("-o", "--output", help="COV.json (parameter set).")],
    old_machine: OldMachine = None,
    machine: MachineName = None,
    since: Since = None,
    values: Annotated[str, typer.Option("--values", help="latest or mean.")] = "latest",
    add_within: Annotated[
        bool,
        typer.Option("--add-within", help="Add the mean within-calibration covariance."),
    ] = False,
    db: Db = None,
) -> None:
    """Long-term covariance of the machine's calibrations, for mtm task uncertainty --long-term."""
    from mtmetrology.history import long_term_covariance, open_history

    when = _date(since, "--since")
    engine = open_history(db, read_only=True)
    result = long_term_covariance(
        engine,
        _one_machine(engine, _machine_argument(old_machine, machine)),
        since=when,
        values=values,
        add_within=add_within,
    )
    result.save(output)
    typer.echo(
        f"long-term covariance of {result.provenance['calibrations']} calibrations "
        f"(rank {result.provenance['rank']}); wrote {output}"
    )


@app.command("export")
@user_errors
def export(
    output: Annotated[Path, typer.Option("-o", "--output", help="FILE.csv or FILE.json.")],
    old_machine: OldMachine = None,
    machine: MachineName = None,
    since: Since = None,
    db: Db = None,
) -> None:
    """Export a machine's calibrations: CSV (one row per run) or JSON (the full runs)."""
    from mtmetrology.history import export_rows, list_runs, open_history, show_run

    when = _date(since, "--since")
    if output.suffix.lower() not in (".json", ".csv"):
        raise InputError(f"{output}: give a .csv or .json file")
    engine = open_history(db, read_only=True)
    machine = _one_machine(engine, _machine_argument(old_machine, machine))
    if output.suffix.lower() == ".json":
        runs = list_runs(engine, machine=machine, since=when)
        write_json(
            output,
            {
                "kind": "history-export",
                "version": 1,
                "machine": machine,
                "runs": [show_run(engine, r.id).to_dict() for r in runs],
            },
        )
    elif output.suffix.lower() == ".csv":
        rows = export_rows(engine, machine, since=when)
        buffer = io.StringIO()
        if rows:
            writer = csv.DictWriter(buffer, fieldnames=list(rows[0]), lineterminator="\n")
            writer.writeheader()
            writer.writerows(rows)
        with atomic_write(output) as fh:
            fh.write(buffer.getvalue())
    typer.echo(f"wrote {output}", err=True)


@app.command("drift")
@user_errors
def drift(
    parameter: Annotated[str, typer.Argument(help="Parameter name, e.g. E_X0C.")],
    machine: MachineName = None,
    mpe: Annotated[
        float | None,
        typer.Option("--mpe", help="Maximum permissible error of |value|, parameter's unit."),
    ] = None,
    reliability: Annotated[
        float, typer.Option("--reliability", help="In-tolerance probability at the due date.")
    ] = 0.95,
    since: Since = None,
    rw_prior: RwPrior = "reference",
    db: Db = None,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="DRIFT.json.")] = None,
    json: Annotated[bool, typer.Option("--json", help="Print DRIFT.json.")] = False,
    k: CoverageK = None,
    p: CoverageP = None,
) -> None:
    """Drift (constant slope + random walk, Kalman filter) and the date the next calibration
    is due: P(|value| > MPE) passes 1 - reliability (ILAC-G24 / OIML D 10, NCSLI RP-1)."""
    from mtmetrology.formatting import format_result, format_value
    from mtmetrology.history import open_history, parameter_drift

    mpe = _mpe(mpe)
    policy = coverage_from_options(k, p)
    when = _date(since, "--since")
    engine = open_history(db, read_only=True)
    result = parameter_drift(
        engine,
        _one_machine(engine, machine),
        parameter,
        mpe=mpe,
        reliability=reliability,
        since=when,
        prior=rw_prior,
        coverage_probability=policy.p,
    )
    document = result.to_dict()

    def summary() -> None:
        per_year = 365.25
        lo, hi = (v * per_year for v in result.slope_interval)
        u_year = result.u_slope * per_year
        slope = format_result(result.slope * per_year, u_year, f"{result.unit}/year", name="slope")
        typer.echo(
            f"{result.parameter}: {result.level:.4f} {result.unit} on "
            f"{result.last_date:%Y-%m-%d}; {slope}, "
            f"{100 * result.coverage_probability:.4g} % interval [{format_value(lo, u_year)}, "
            f"{format_value(hi, u_year)}]; random "
            f"walk {math.sqrt(result.random_walk_variance * per_year):.2g} {result.unit}/√year "
            f"(estimate; marginalised under the {result.prior} prior, mean "
            f"{math.sqrt(result.random_walk_variance_mean * per_year):.2g})"
        )
        if result.mpe is not None:
            due = "beyond the horizon" if result.due_date is None else f"{result.due_date:%Y-%m-%d}"
            typer.echo(
                f"due: {due} (P(|{result.parameter}| > {result.mpe:g} {result.unit}) passes "
                f"{1 - result.reliability:.3g})"
            )

    emit_result(document, summary, output=output, report=None, report_path=None, as_json=json)


# Display unit of a certificate quantity by its SI unit (ISO 230-1 customary units).
_DISPLAY = {"m": "µm", "rad": "µrad", "1": "µm/m"}


def _print_certificate(cert) -> None:
    from mtmetrology.formatting import format_k, format_uncertainty, format_value
    from mtmetrology.units import from_internal

    typer.echo(
        f"{cert.identifier}: {cert.item}, {cert.laboratory} ({cert.country}), "
        f"{cert.begin.isoformat()} to {cert.end.isoformat()}; U = k u with "
        f"k = {cert.coverage_factor:g}, p = {cert.coverage_probability:.4f}"
    )
    region = cert.region
    if region.dimension > 1:
        typer.echo(
            f"  ellipsoidal region of the {region.dimension} quantities jointly: "
            f"k = {region.coverage_factor:.3g}, p = {region.coverage_probability:.4f} "
            "(JCGM 102 6.5.2.3)"
        )
    values, u, _ = cert.internal()
    for name, si, value, s in zip(cert.names, cert.units, values, u, strict=True):
        unit = _DISPLAY[si]
        big_u = float(from_internal(cert.coverage_factor * s, unit))
        typer.echo(
            f"  {name:<10} {format_value(float(from_internal(value, unit)), big_u / 2):>14} "
            f"{unit}, U = {format_uncertainty(big_u)} {unit} "
            f"(k = {format_k(cert.coverage_factor)})"
        )


@app.command("dcc")
@user_errors
def dcc(
    run: Annotated[int, typer.Argument(help="Calibration run number (mtm history list).")],
    output: Annotated[Path, typer.Option("-o", "--output", help="CERT.xml to write.")],
    laboratory: Annotated[str, typer.Option("--laboratory", help="Laboratory name.")],
    email: Annotated[str, typer.Option("--email", help="Laboratory e-mail address.")],
    country: Annotated[
        str, typer.Option("--country", help="Laboratory country, ISO 3166-1 alpha-2 (DE).")
    ],
    responsible_person: Annotated[
        str, typer.Option("--responsible-person", help="Person responsible for the certificate.")
    ],
    manufacturer: Annotated[str, typer.Option("--manufacturer", help="Machine manufacturer.")],
    customer: Annotated[
        str | None, typer.Option("--customer", help="Customer [the laboratory: in-house].")
    ] = None,
    coverage_factor: Annotated[
        float, typer.Option("--coverage-factor", help="k of U = k u (>= 1).")
    ] = 2.0,
    db: Db = None,
) -> None:
    """Export a calibration run as a PTB Digital Calibration Certificate (DCC 3.1.2), with
    the run's recorded temperature and artefact."""
    from mtmetrology.history import open_history, show_run
    from mtmetrology.history.dcc import calibration_certificate

    record = show_run(open_history(db, read_only=True), run)
    cert = calibration_certificate(
        record,
        laboratory=laboratory,
        email=email,
        country=country,
        responsible_person=responsible_person,
        manufacturer=manufacturer,
        customer=customer,
        coverage_factor=coverage_factor,
    )
    xml = cert.to_xml()
    with atomic_write(output, "wb", encoding=None) as fh:
        fh.write(xml)
    _print_certificate(cert)
    typer.echo(f"wrote {output}", err=True)


@app.command("dcc-import")
@user_errors
def dcc_import(
    certificate: Annotated[Path, typer.Argument(help="A DCC (XML), e.g. an artefact's.")],
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Write the values as JSON.")
    ] = None,
    scale_bar: Annotated[
        Path | None,
        typer.Option(
            "--scale-bar",
            help="SAMBA artefact (YAML) whose scale_bar length_mm and u_mm the certificate "
            "sets; -o then writes the updated artefact.",
        ),
    ] = None,
    quantity: Annotated[
        str | None, typer.Option("--quantity", help="The certified length (default: the only).")
    ] = None,
    ball_plate: Annotated[
        Path | None,
        typer.Option(
            "--ball-plate",
            help="Ball-plate file (kind: ball-plate) whose centres and covariance_mm2 the "
            "certificate sets (quantities ID_x, ID_y, ID_z); -o then writes the updated plate.",
        ),
    ] = None,
    json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Read a DCC (a scale bar's or ball plate's certificate): values, u and covariance."""
    from mtmetrology.history.dcc_read import (
        certified_ball_centres,
        certified_length,
        read_certificate,
    )
    from mtmetrology.io.documents import load_document
    from mtmetrology.units import from_internal

    cert = read_certificate(certificate)
    document = cert.to_dict()
    if scale_bar is not None:
        document = load_document(scale_bar, "SAMBA artefact")
        if not isinstance(document.get("scale_bar"), dict):
            raise InputError(f"{scale_bar}: scale_bar: missing (ends, length_mm, u_mm)")
        nominal = document["scale_bar"].get("length_mm")
        length, u = certified_length(
            cert, quantity, nominal if isinstance(nominal, int | float) else None
        )
        document["scale_bar"] = {**document["scale_bar"], "length_mm": length, "u_mm": u}
        typer.echo(
            f"scale bar {cert.identifier}: {length:.6f} mm, u = {from_internal(u, 'µm'):.2g} µm",
            err=True,
        )
    if ball_plate is not None:
        if scale_bar is not None:
            raise InputError("--scale-bar and --ball-plate: give one artefact")
        document = load_document(ball_plate, "ball plate")
        balls = document.get("balls")
        if not isinstance(balls, list) or not all(isinstance(b, dict) for b in balls):
            raise InputError(f"{ball_plate}: balls: missing (a list of id, x_mm, y_mm, z_mm)")
        centres, covariance = certified_ball_centres(cert, [str(b.get("id")) for b in balls])
        for ball, centre in zip(balls, centres.tolist(), strict=True):
            ball.update(x_mm=centre[0], y_mm=centre[1], z_mm=centre[2])
        document.pop("u_mm", None)
        document["covariance_mm2"] = covariance.tolist()
        typer.echo(f"ball plate {cert.identifier}: {len(balls)} centres", err=True)
    emit_result(
        document,
        lambda: _print_certificate(cert),
        output=output,
        report=None,
        report_path=None,
        as_json=json,
    )
