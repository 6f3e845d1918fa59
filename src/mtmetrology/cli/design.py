"""``mtm samba plan`` and ``mtm samba compare-plans``: plan a SAMBA calibration (balls and
probing programme by DETMAX); commands of the ``mtm samba`` group."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table as RichTable

from mtmetrology.cli._common import (
    ErrorModelOption,
    MachineOption,
    ReportOption,
    command_line,
    emit_result,
    parse_tools,
    user_errors,
)
from mtmetrology.cli._progress import progress_bar
from mtmetrology.design.choices import CRITERIA
from mtmetrology.design.counts import MINUTES_PER_MEASUREMENT
from mtmetrology.errors import InputError
from mtmetrology.io.files import atomic_write

app = typer.Typer(
    help="Plan calibrations: artefact layout and probing programme.", no_args_is_help=True
)


def _positive(value: float, option: str, allow_zero: bool = False) -> None:
    ok = math.isfinite(value) and (value >= 0 if allow_zero else value > 0)
    if not ok:
        raise InputError(
            f"{option} must be a {'non-negative' if allow_zero else 'positive'} number, got {value}"
        )


def _artefact_yaml(design, ball_diameter_mm: float) -> str:
    p = design.programme
    lines = ["kind: samba-artefact", "balls:"]
    for b in (*p.ball_ids, *p.bar.ends):
        lines.append(f'  - {{id: "{b}", diameter_mm: {ball_diameter_mm:g}}}')
    ends = ", ".join(f'"{e}"' for e in p.bar.ends)
    lines.append(
        f"scale_bar: {{ends: [{ends}], length_mm: {p.bar.length:.6f}, u_mm: {p.bar.u_mm:g}}}"
    )
    if p.tools is not None:
        lines.append("tools:")
        for t, (x, y, z) in p.tools:
            lines.append(f'  - {{id: "{t}", vector_mm: [{x:g}, {y:g}, {z:g}]}}')
    return "\n".join(lines) + "\n"


def _balls_yaml(doc: dict) -> str:
    """The chosen balls and the scale-bar ends as ``samba-balls`` (nominal centres, mm)."""
    bar = doc["scale_bar"]
    placed = [(b["id"], b["centre_mm"]) for b in doc["balls"]]
    placed += list(zip(bar["ends"], bar["centres_mm"], strict=True))
    lines = ["kind: samba-balls", "balls:"]
    for ball_id, (x, y, z) in placed:
        lines.append(f'  - {{id: "{ball_id}", centre_mm: [{x:.6f}, {y:.6f}, {z:.6f}]}}')
    return "\n".join(lines) + "\n"


@app.command("samba")
@user_errors
def samba(
    ctx: typer.Context,
    machine: MachineOption,
    output: Annotated[Path, typer.Option("-o", "--output", help="Programme CSV to write.")],
    model: ErrorModelOption = None,
    params_only: Annotated[
        str | None,
        typer.Option("--params-only", help="Plan for these parameters only (E_X0C,E_AY1,...)."),
    ] = None,
    tool: Annotated[
        list[str] | None,
        typer.Option(
            "--tool",
            help="A stylus ID=x,y,z (mm); two or more: the programme is probed with each "
            "(both the ball and the indexation choice).",
        ),
    ] = None,
    balls_from: Annotated[
        Path | None,
        typer.Option("--balls-from", help="Candidate ball grid YAML (step 1 chooses --n-balls)."),
    ] = None,
    balls: Annotated[
        Path | None, typer.Option("--balls", help="Placed balls YAML (step 2 only).")
    ] = None,
    n_balls: Annotated[
        int | None, typer.Option("--n-balls", help="Balls to choose from the grid.")
    ] = None,
    indexations: Annotated[
        Path | None, typer.Option("--indexations", help="Candidate indexations CSV: B,C (deg).")
    ] = None,
    b_grid: Annotated[
        str | None,
        typer.Option("--b-grid", help="Candidate B angles: start:stop:step or list, deg."),
    ] = None,
    c_grid: Annotated[
        str | None,
        typer.Option("--c-grid", help="Candidate C angles: start:stop:step or list, deg."),
    ] = None,
    k: Annotated[float, typer.Option("--k", help="Multiple of unknowns/3 (strategy xB.kn).")] = 3.0,
    count_rule: Annotated[
        str,
        typer.Option(
            "--count-rule",
            help="source: the source's reading for the model (13: indexations, else "
            "measurements); indexations: M = k*ceil(U/3) indexations; measurements: "
            "M_T ~ k*U/3.",
        ),
    ] = "source",
    criterion: Annotated[
        str,
        typer.Option(
            "--criterion",
            help=f"One of {', '.join(CRITERIA)} (D and A are the fastest: rank-r updates).",
        ),
    ] = "O2",
    starts: Annotated[int, typer.Option("--starts", help="Random DETMAX starts.")] = 8,
    seed: Annotated[int | None, typer.Option("--seed", help="Seed of the random starts.")] = None,
    executor: Annotated[
        str | None,
        typer.Option("--executor", help="inprocess, processes[:n], dask-local[:n] or an address."),
    ] = None,
    sigma_um: Annotated[
        float, typer.Option("--sigma-um", help="Probing noise: u of one coordinate, µm.")
    ] = 1.0,
    accessibility: Annotated[
        Path | None, typer.Option("--accessibility", help="Accessibility rule YAML.")
    ] = None,
    minutes_per_measurement: Annotated[
        float,
        typer.Option("--minutes-per-measurement", help="Duration a, min per ball measurement."),
    ] = MINUTES_PER_MEASUREMENT,
    minutes_per_indexation: Annotated[
        float, typer.Option("--minutes-per-indexation", help="Duration b, min per indexation.")
    ] = 0.0,
    artefact_out: Annotated[
        Path | None,
        typer.Option("--artefact-out", help="Also write the samba-artefact YAML (scale bar)."),
    ] = None,
    balls_out: Annotated[
        Path | None,
        typer.Option(
            "--balls-out", help="Also write the samba-balls YAML (nominal centres, for simulate)."
        ),
    ] = None,
    json: Annotated[bool, typer.Option("--json", help="Print the design as JSON.")] = False,
    report_path: ReportOption = None,
) -> None:
    """Choose SAMBA balls and (B, C) indexations by DETMAX; write the probing programme.

    The programme CSV has columns ball,B,C,S,X,Y,Z (+ sense_B,sense_C for models with
    backlash): X,Y,Z are the nominal readings at the ball centre, so `mtm machine
    identifiability MACHINE PROGRAMME.csv --artefact ARTEFACT.yaml` reads it as is, and
    `mtm samba simulate --poses PROGRAMME.csv --balls BALLS.yaml --artefact ARTEFACT.yaml`
    (with the files of --balls-out and --artefact-out) simulates the planned test.

    With two or more --tool styli every row is probed with each (a tool column), balls
    from --balls-from are chosen for the multi-stylus programme, and the plan reports
    what the styli after the first buy: the parameters the first alone confounds, the
    condition number and the predicted u with one stylus and with all.
    """
    from mtmetrology.design.accessibility import AccessibilityRule, load_accessibility_rule
    from mtmetrology.design.counts import COUNT_RULES
    from mtmetrology.design.inputs import (
        SEED004_GRID,
        axis_grid,
        default_indexations,
        grid_indexations,
        load_ball_grid,
        load_balls,
        read_indexations,
    )
    from mtmetrology.design.samba import plan_samba
    from mtmetrology.io.tables import write_csv_table
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.units import to_internal

    _positive(sigma_um, "--sigma-um")
    _positive(k, "--k")
    _positive(minutes_per_measurement, "--minutes-per-measurement")
    _positive(minutes_per_indexation, "--minutes-per-indexation", allow_zero=True)
    if count_rule not in COUNT_RULES:
        raise InputError(f"--count-rule {count_rule!r}: choose one of {', '.join(COUNT_RULES)}")
    if balls is not None and balls_from is not None:
        raise InputError("give --balls (placed balls) or --balls-from (candidate grid), not both")
    m = Machine.load(machine, model)
    if params_only:
        m = m.with_parameters([n.strip() for n in params_only.split(",") if n.strip()])
    styli = parse_tools(tool)
    rule = load_accessibility_rule(accessibility) if accessibility else AccessibilityRule()
    if indexations is not None and (b_grid or c_grid):
        raise InputError("give --indexations or --b-grid/--c-grid, not both")
    if indexations is not None:
        pairs = read_indexations(indexations)
    elif b_grid or c_grid:
        if not (b_grid and c_grid):
            raise InputError("--b-grid and --c-grid go together")
        pairs = grid_indexations(axis_grid(b_grid, "--b-grid"), axis_grid(c_grid, "--c-grid"))
    else:
        pairs = default_indexations()
    if balls is not None:
        spec = load_balls(balls)
        placed = ([b.id for b in spec.balls], [b.centre_mm for b in spec.balls])
        candidates, bar = None, spec.scale_bar
    else:
        grid = load_ball_grid(balls_from) if balls_from else SEED004_GRID
        placed, bar = None, grid.scale_bar
        candidates = grid.candidates(rule.table_z_mm)
    design = plan_samba(
        m,
        pairs,
        balls=placed,
        candidates=candidates,
        n_balls=n_balls,
        k=k,
        count_rule=count_rule,
        criterion=criterion,
        bar=bar,
        rule=rule,
        sigma_mm=float(to_internal(sigma_um, "µm")),
        starts=starts,
        seed=seed,
        executor=executor,
        tools=None if styli is None else list(styli.items()),
    )
    header, rows = design.programme.table()
    if artefact_out is not None:
        with atomic_write(artefact_out) as fh:
            fh.write(_artefact_yaml(design, rule.ball_diameter_mm))
    doc = design.to_dict(minutes_per_measurement, minutes_per_indexation)
    if balls_out is not None:
        with atomic_write(balls_out) as fh:
            fh.write(_balls_yaml(doc))
    report = None
    if report_path is not None:
        inputs = [machine, balls, balls_from, indexations, accessibility]
        report = _design_report(design, command_line(ctx), inputs, doc)
    write_csv_table(output, header, rows)
    emit_result(
        doc,
        lambda: _print(doc, output),
        output=None,
        report=report,
        report_path=report_path,
        as_json=json,
    )


def _design_report(design, command: str, inputs: list, doc: dict):
    import mtmetrology.design.report  # noqa: F401  (registers the plan renderer)
    from mtmetrology.report import Report
    from mtmetrology.report.results import add_result

    provenance = {"inputs": [str(p) for p in inputs if p is not None and Path(p).is_file()]}
    report = Report("SAMBA calibration plan", command=command, provenance=provenance)
    timing = {
        "minutes_per_measurement": doc["minutes_per_measurement"],
        "minutes_per_indexation": doc["minutes_per_indexation"],
    }
    return add_result(report, design, **timing)


def _print(doc: dict, output: Path) -> None:
    from mtmetrology.formatting import format_uncertainty

    console = Console()
    console.print(
        f"[bold]{doc['machine']}[/bold] model {doc['model'] or 'custom'}: "
        f"criterion {doc['criterion']}, "
        f"k = {doc['k']:g}, {doc['count_rule']} count rule ({doc['count_rule_reason']})"
    )
    bt = RichTable(title="master balls")
    for col in ("id", "x mm", "y mm", "z mm (stem)"):
        bt.add_column(col)
    for b in doc["balls"]:
        x, y, z = b["centre_mm"]
        bt.add_row(b["id"], f"{x:g}", f"{y:g}", f"{z:g}")
    console.print(bt)
    console.print(
        f"{doc['n_indexations']} indexations of {doc['n_accessible_indexations']} accessible "
        f"({doc['n_candidate_indexations']} candidates); {doc['n_measurements']} measurements; "
        f"duration ≈ {doc['duration_h']:.2f} h (a = {doc['minutes_per_measurement']:g} min/"
        f"measurement, b = {doc['minutes_per_indexation']:g} min/indexation)"
    )
    console.print(
        f"rank {doc['rank']} of {doc['n_unknowns']}, condition {doc['condition_scaled']:.4g} "
        "(columns scaled); " + ", ".join(f"{k} {v:.4g}" for k, v in doc["observability"].items())
    )
    gain = doc["stylus_gain"]
    if gain is not None:
        one, every = gain["one_stylus"], gain["all_styli"]
        console.print(
            f"first stylus alone: rank {one['rank']} of {one['n_unknowns']}, confounded "
            f"{'; '.join(' ~ '.join(g) for g in one['confounded']) or 'none'}; all styli: "
            f"rank {every['rank']} of {every['n_unknowns']}; resolved: "
            f"{', '.join(gain['resolved']) or 'none'}"
        )
    for step in ("step1", "step2"):
        s = doc[step]
        if s:
            console.print(
                f"{step}: {s['criterion']} {s['best_start_value']:.6g} -> {s['best_value']:.6g} "
                f"in {s['exchanges']} exchanges ({s['stop']})"
            )
    pt = RichTable(
        title=f"predicted standard uncertainty (probing σ = {doc['probing_sigma_um']:g} µm)"
    )
    for col in ("parameter", "u", "unit"):
        pt.add_column(col)
    for p in doc["parameters"]:
        pt.add_row(p["name"], format_uncertainty(p["u"]), p["unit"])  # GUM 7.2.6
    console.print(pt)
    console.print(f"programme written to {output}")


def _list(text: str, option: str, cast):
    try:
        values = [cast(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise InputError(f"{option} {text!r}: a comma-separated list of numbers") from None
    if not values:
        raise InputError(f"{option}: give at least one value")
    return values


@app.command("compare")
@user_errors
def compare(
    ctx: typer.Context,
    machine: MachineOption,
    balls: Annotated[
        Path, typer.Option("--balls", help="Placed balls YAML; n balls = the first n.")
    ],
    model: ErrorModelOption = None,
    n_balls: Annotated[str, typer.Option("--n-balls", help="Ball counts, e.g. 1,2,3,4.")] = "1,4",
    k: Annotated[str, typer.Option("--k", help="Multiples of unknowns/3, e.g. 2,3,5.")] = "2,3",
    criterion: Annotated[
        str, typer.Option("--criterion", help=f"Criteria among {', '.join(CRITERIA)}.")
    ] = "O2",
    indexations: Annotated[
        Path | None, typer.Option("--indexations", help="Candidate indexations CSV: B,C (deg).")
    ] = None,
    sigma_um: Annotated[
        float, typer.Option("--sigma-um", help="Probing noise: u of one coordinate, µm.")
    ] = 1.0,
    gauge_mm: Annotated[
        float, typer.Option("--gauge-mm", help="Gauge-block length of the simulated check.")
    ] = 300.0,
    starts: Annotated[int, typer.Option("--starts", help="Random DETMAX starts.")] = 3,
    seed: Annotated[int, typer.Option("--seed", help="Seed of starts, truth and tests.")] = 0,
    output: Annotated[
        Path | None, typer.Option("-o", "--output", help="Write the comparison JSON.")
    ] = None,
    json: Annotated[bool, typer.Option("--json", help="Print the comparison as JSON.")] = False,
    report_path: ReportOption = None,
) -> None:
    """Compare SAMBA strategies: balls x k x criterion, each planned by DETMAX and checked.

    Each strategy: indexations, measurements, duration, condition number (all candidates,
    DETMAX start and end), predicted u and UPF per parameter, and a simulated gauge-block
    check (nominal and compensated model). Alami Mchichi (2018) Tables 5.2, 5.3, 5.5.
    """
    from mtmetrology.design.compare import compare_strategies
    from mtmetrology.design.inputs import default_indexations, load_balls, read_indexations
    from mtmetrology.kinematics.machine import Machine
    from mtmetrology.units import to_internal

    _positive(sigma_um, "--sigma-um")
    _positive(gauge_mm, "--gauge-mm")
    m = Machine.load(machine, model)
    spec = load_balls(balls)
    pairs = read_indexations(indexations) if indexations is not None else default_indexations()
    with progress_bar("strategies") as progress:
        result = compare_strategies(
            m,
            pairs,
            ([b.id for b in spec.balls], [b.centre_mm for b in spec.balls]),
            n_balls=_list(n_balls, "--n-balls", int),
            ks=_list(k, "--k", float),
            criteria=[c.strip() for c in criterion.split(",") if c.strip()],
            bar=spec.scale_bar,
            sigma_mm=float(to_internal(sigma_um, "µm")),
            gauge_length_mm=gauge_mm,
            starts=starts,
            seed=seed,
            progress=progress,
        )
    doc = result.to_dict()
    report = None
    if report_path is not None:
        import mtmetrology.design.report  # noqa: F401  (registers the renderer)
        from mtmetrology.report import Report
        from mtmetrology.report.results import add_result

        report = add_result(Report("SAMBA strategy comparison", command=command_line(ctx)), result)

    def summary() -> None:
        header, rows = result.table()
        table = RichTable(title=f"SAMBA strategies, {doc['model']}-parameter model")
        for col in header:
            table.add_column(col)
        for row in rows:
            table.add_row(*[str(v) for v in row])
        Console().print(table)

    emit_result(
        doc,
        summary,
        output=output,
        report=report,
        report_path=report_path,
        as_json=json,
    )
