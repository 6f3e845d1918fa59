"""``mtm samba long-term``: the day-to-day covariance of several calibrations.

A command of the ``mtm samba`` group (:data:`mtmetrology.cli.SHARED_GROUPS`).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from mtmetrology.cli._common import emit_result, user_errors
from mtmetrology.errors import InputError

if TYPE_CHECKING:
    from mtmetrology.kinematics.parameter_set import ParameterSet

app = typer.Typer()

LONG_TERM_HELP = """Long-term parameter covariance from several calibrations of one machine.

CAL.json: parameter sets or calibration results (mtm samba calibrate -o), one per day, in
time order. They must name the same machine, error model and parameters.

LONGTERM.json (kind parameter-set): the values of the latest calibration (--values mean:
their mean) and, as covariance, the day-to-day sample covariance of the estimates (n - 1
divisor; Sepahi Boroujeni (2021), Tables 5-2 'Exp.' and 5-4). --add-within adds the mean
of the calibrations' own covariances, for what every calibration shares and the scatter
cannot show (the scale bar's length error); it counts the probing noise twice.
'mtm task uncertainty --params LONGTERM.json' reads it as it is.
"""


@app.command("long-term", help=LONG_TERM_HELP)
@user_errors
def long_term(
    calibrations: Annotated[
        list[Path], typer.Argument(help="CAL.json files (two or more), oldest first.")
    ],
    output: Annotated[Path | None, typer.Option("-o", "--output", help="LONGTERM.json.")] = None,
    machine: Annotated[
        str | None,
        typer.Option("--machine", help="Preset name or machine YAML [the machine the files name]."),
    ] = None,
    values: Annotated[
        str, typer.Option("--values", help="Parameter values: latest or mean.")
    ] = "latest",
    add_within: Annotated[
        bool,
        typer.Option("--add-within", help="Add the mean within-calibration covariance."),
    ] = False,
    json: Annotated[bool, typer.Option("--json", help="Print LONGTERM.json.")] = False,
) -> None:
    from mtmetrology.identification.long_term import VALUE_CHOICES, long_term_parameters
    from mtmetrology.io.documents import load_document
    from mtmetrology.io.plausibility import distinct_files
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.parameter_set import ParameterSet

    if values not in VALUE_CHOICES:
        raise InputError(f"--values must be one of {', '.join(VALUE_CHOICES)}, got {values!r}")
    if len(calibrations) < 2:
        raise InputError(
            f"give at least 2 calibration files, got {len(calibrations)}: a covariance "
            "needs the scatter of several days"
        )
    distinct_files(calibrations, "calibration files")
    documents = [load_document(p, "parameter set") for p in calibrations]
    if machine is None:
        named = documents[0].get("machine") if isinstance(documents[0], dict) else None
        if not isinstance(named, str):
            raise InputError(f"{calibrations[0]}: machine: missing; give --machine")
        machine = named
    base = Machine.load(machine)
    sets = [
        ParameterSet.from_document(doc, base, str(path))
        for doc, path in zip(documents, calibrations, strict=True)
    ]
    result = long_term_parameters(
        sets, values=values, add_within=add_within, sources=[str(p) for p in calibrations]
    )
    if output is not None:
        result.save(output)  # JSON or YAML by its suffix (ParameterSet.save)
    emit_result(
        result.to_document(),
        lambda: _summary(result, output),
        output=None,
        report=None,
        report_path=None,
        as_json=json,
    )


def _summary(result: ParameterSet, output: Path | None) -> None:
    """Values with their standard uncertainty u (two significant digits, JCGM 100 7.2.6)."""
    from mtmetrology.formatting import format_uncertainty, format_value

    f = result.scales()
    u = result.standard_uncertainty
    prov = result.provenance
    typer.echo(
        f"long-term covariance of {prov['calibrations']} calibrations (rank {prov['rank']}); "
        f"values: {prov['values']}"
    )
    for name, value, unc, unit, scale in zip(
        result.names, result.values, u, result.units, f, strict=True
    ):
        u_c = float(unc / scale)
        typer.echo(
            f"  {name:<8} {format_value(float(value / scale), u_c):>12} {unit:<4}  "
            f"u = {format_uncertainty(u_c)} {unit}"
        )
    if output is not None:
        typer.echo(f"wrote {output}", err=True)
