"""``mtm laser simulate``, ``mtm laser analyse``: ISO 230-2 positioning tests of a linear
axis with a laser interferometer (:mod:`mtmetrology.positioning`).

Each command parses its options, calls one library function and prints (or writes) its
result; the library is imported inside the commands.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from mtmetrology.cli._common import (
    ErrorModelOption,
    ReportOption,
    command_line,
    emit_result,
    fail,
    user_errors,
)

app = typer.Typer(
    no_args_is_help=True,
    help="ISO 230-2 positioning tests with a laser interferometer: simulate, analyse.",
)

_CONDITIONS_HELP = (
    "CONDITIONS.yaml (kind iso230-2-conditions): axis, travel_mm, approach, overrun_mm, "
    "air_temperature_C, air_pressure_Pa, humidity_percent, material_temperatures_C, "
    "expansion_scale_per_K, expansion_material_per_K, wavelength_nm, air_compensated, "
    "nde_applied, datum_mm; the CSV's '# key: value' header lines otherwise."
)


@app.command("simulate")
@user_errors
def simulate(
    machine: Annotated[str, typer.Option("--machine", help="Preset name or machine YAML.")],
    output: Annotated[Path, typer.Option("-o", "--output", help="TEST.csv to write.")],
    truth: Annotated[
        Path | None,
        typer.Option("--truth", help="TRUTH.json parameter set with E_XX terms (zero if omitted)."),
    ] = None,
    axis: Annotated[str, typer.Option("--axis", help="Linear axis tested.")] = "X",
    targets: Annotated[int, typer.Option("--targets", help="Targets over the travel.")] = 11,
    runs: Annotated[int, typer.Option("--runs", help="Runs per direction.")] = 5,
    sigma_um: Annotated[
        float, typer.Option("--sigma-um", help="Scatter of one reading, µm (standard deviation).")
    ] = 0.5,
    seed: Annotated[int | None, typer.Option("--seed", help="Random seed.")] = None,
) -> None:
    """A virtual ISO 230-2 test of an axis with known errors, as the neutral CSV."""
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.kinematics.parameter_set import ParameterSet
    from mtmetrology.positioning.identify import axis_machine
    from mtmetrology.positioning.simulate import iso_targets, simulate_test
    from mtmetrology.units import to_internal

    m = Machine.load(machine)
    axis = axis.upper()
    sub = axis_machine(m, axis)
    pset = ParameterSet.zeros(sub) if truth is None else ParameterSet.load(truth, m)
    travel = m.axes[axis].travel
    if travel is None:
        fail(f"--axis: {axis} has no travel in {m.name}")
    t = iso_targets(travel[0], travel[1], targets, seed=seed)
    test = simulate_test(
        m, pset, axis, t, runs=runs, sigma_mm=to_internal(sigma_um, "µm"), seed=seed
    )
    test.write(output)
    typer.echo(f"wrote {t.size} targets x {runs} runs x 2 directions to {output}", err=True)


@app.command("analyse")
@user_errors
def analyse(
    ctx: typer.Context,
    test: Annotated[
        Path, typer.Argument(help="TEST.csv: target,position_mm,run,direction,deviation_um.")
    ],
    conditions: Annotated[Path | None, typer.Option("--conditions", help=_CONDITIONS_HELP)] = None,
    edition: Annotated[
        str, typer.Option("--edition", help="2014, 2006, 1997, 1988 (ISO 230-2) or vdi3441.")
    ] = "2014",
    machine: Annotated[
        str | None,
        typer.Option("--machine", help="Preset or YAML: also identify E_XX, E_XXb (ISO 230-1)."),
    ] = None,
    model: ErrorModelOption = None,
    degrees: Annotated[
        str | None,
        typer.Option("--degrees", help="Degrees of E_XX to identify, e.g. 1,2,3,4 (the model's)."),
    ] = None,
    budget: Annotated[
        Path | None,
        typer.Option(
            "--budget",
            help="BUDGET.yaml: ISO/TR 230-9 inputs replacing the defaults (keys of "
            "mtmetrology.positioning.budget.DEFAULTS, e.g. dead_path_mm: 120).",
        ),
    ] = None,
    json: Annotated[bool, typer.Option("--json", help="Print RESULT.json.")] = False,
    output: Annotated[Path | None, typer.Option("-o", "--output", help="RESULT.json.")] = None,
    report_path: ReportOption = None,
) -> None:
    """The ISO 230-2 parameters of the edition with U (k = 2, ISO/TR 230-9), the
    environmental correction applied (Edlén air index, NDE to 20 °C), the pitch table and,
    with --machine, the axis's E_XX and E_XXb with covariance (mtm export reads RESULT)."""
    from mtmetrology.positioning.data import read_test
    from mtmetrology.positioning.workflow import analyse as run

    m = None
    if machine is not None:
        from mtmetrology.kinematics.machine import Machine

        m = Machine.load(machine, model)
    given = None
    if budget is not None:
        from mtmetrology.io.documents import load_document

        given = load_document(budget, "ISO/TR 230-9 budget inputs")
        if not isinstance(given, dict):
            fail(f"{budget}: must be a mapping of budget inputs")
    chosen = None
    if degrees is not None:
        try:
            chosen = [int(d) for d in degrees.split(",")]
        except ValueError:
            fail(f"--degrees: {degrees!r} is not a list of whole numbers")
        if not chosen or min(chosen) < 1:
            fail(f"--degrees: {degrees!r}: degrees are 1 or more")
    result = run(
        read_test(test, conditions),
        edition=edition,
        machine=m,
        degrees=chosen,
        budget_inputs=given,
    )
    report = None
    if report_path is not None:
        from mtmetrology.positioning.report import positioning_report

        report = positioning_report(result, command_line(ctx), [test])
    emit_result(
        result.to_dict(),
        result.summary(),
        output=output,
        report=report,
        report_path=report_path,
        as_json=json,
    )
