"""The five-axis machine of the SAMBA examples and whether a SAMBA plan identifies it.

Prints the 13 error parameters of the machine's SAMBA model (Alami Mchichi (2018),
Table 5.1) with what a positive value does and where it is referred, then the rank and
scaled condition number of the identification of a plan of four master balls and a scale
bar probed at 30 (B, C) orientations: full rank with 13 parameters, rank deficient with
E_Y0C added (its confound with E_Y0S named). Run it on its own::

    python examples/five_axis_machine.py [OUT]

References
----------
Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes*. PhD thesis, École
Polytechnique de Montréal.
"""

from __future__ import annotations

from _five_axis import ARTEFACT_YAML, BAR_U_MM, GRID, PRESET, PROBING_SIGMA_UM, SETUP
from mtmetrology.identification import BallCentreProblem, ScaleBar, analyse_identifiability
from mtmetrology.io.tables import write_csv_table
from mtmetrology.kinematics.conventions import describe_parameters
from mtmetrology.kinematics.machine import Machine
from mtmetrology.report.demo import DemoContext
from mtmetrology.report.results import add_result
from mtmetrology.samba import probing_sequence
from mtmetrology.units import to_internal


def _indications_csv(ctx: DemoContext, m: Machine, ids, q, *parts: str) -> None:
    rows = (
        [i, *(f"{v:.6f}" for v in r)] for i, r in zip(ids, m.readings_to_customary(q), strict=True)
    )
    write_csv_table(ctx.path(*parts), ["ball", *m.axis_names], rows)


def machine_section(ctx: DemoContext) -> None:
    m = Machine.load(PRESET)
    ctx.report.section(
        "The machine",
        f"{m.name}: topology {m.topology.string} (the table carries X, B and C; the spindle "
        f"head Z, Y and the spindle S). Its {m.n_params}-parameter SAMBA model (Alami Mchichi "
        "(2018), Table 5.1), with what a positive value does to the tool relative to the "
        "workpiece and where each parameter is referred to:",
    )
    ctx.report.table(
        ["parameter", "unit", "a positive value", "referred to"],
        [[c.name, c.unit, c.positive, c.reference] for c in describe_parameters(m)],
    )
    ctx.command("the parameters and their conventions", "machine", "show", PRESET)
    ctx.summary.append(f"machine: {m.name}, {m.n_params} parameters of model {m.model_name}")


def identifiability_section(ctx: DemoContext) -> None:
    m = Machine.load(PRESET)
    ids, q = probing_sequence(m, SETUP, GRID)
    _indications_csv(ctx, m, ids, q, "samba", "plan.csv")
    ctx.write_text(ARTEFACT_YAML, "samba", "samba.yaml")
    bar = ScaleBar(("SB1", "SB2"), SETUP.scale_bar_length, u=BAR_U_MM)
    sigma = float(to_internal(PROBING_SIGMA_UM, "µm"))
    reports = {}
    with ctx.step("identifiability of the plan: 13 parameters, then 13 + E_Y0C"):
        for label, model in (
            ("13 parameters", m),
            ("13 + E_Y0C", m.with_parameters([*m.parameter_names, "E_Y0C"])),
        ):
            problem = BallCentreProblem(
                model, q, ids, scale_bars=[bar], estimate_tool=True, sigma=sigma
            )
            _, jac = problem.evaluate(problem.initial())
            reports[label] = analyse_identifiability(
                jac, problem.names, n_measurements=len(ids), report_names=model.parameter_names
            )
    ctx.report.section(
        "Is the SAMBA plan good enough?",
        f"Four master balls and a scale bar probed at {len(GRID)} (B, C) orientations with "
        "spindle indexing: the ball centres and the tool offset are unknown too. The plan "
        "identifies the 13 parameters; adding E_Y0C makes it rank deficient, and the "
        "confounded parameters are named.",
    )
    ctx.report.table(
        ["model", "unknowns", "rank", "condition (scaled)", "unidentifiable"],
        [
            [
                label,
                r.n_unknowns,
                r.rank,
                f"{r.condition_scaled:.4g}" if r.full_rank else "—",
                "; ".join(map(str, r.null_directions)) or "none",
            ]
            for label, r in reports.items()
        ],
    )
    add_result(ctx.report, reports["13 parameters"])
    plan, artefact = ctx.shown("samba", "plan.csv"), ctx.shown("samba", "samba.yaml")
    check = ("machine", "identifiability", PRESET, plan, "--artefact", artefact)
    ctx.command("identifiability of the plan", *check)
    ctx.command("the confound E_Y0C ~ E_Y0S (exits with code 2)", *check, "--add", "E_Y0C")
    deficient = reports["13 + E_Y0C"]
    ctx.summary.append(
        f"SAMBA plan: rank {reports['13 parameters'].rank}/{reports['13 parameters'].n_unknowns}"
        f"; with E_Y0C rank {deficient.rank}/{deficient.n_unknowns} "
        f"({'; '.join(map(str, deficient.null_directions))})"
    )


def main(ctx: DemoContext) -> None:
    ctx.rule("The five-axis machine")
    machine_section(ctx)
    ctx.rule("SAMBA plan: identifiability")
    identifiability_section(ctx)


if __name__ == "__main__":
    from mtmetrology.report.demo import run_example

    run_example(main, "five_axis_machine")
