"""Planning a SAMBA test by DETMAX: the balls and (B, C) indexations of a five-axis test.

Two balls are chosen from a grid of twelve candidates (three positions in X, two in Y, two
stem lengths) and then the (B, C) indexations, by the D criterion, for the 13-parameter
model (Alami Mchichi 2018, §5.5–5.7); the predicted standard uncertainty of every parameter
and the test duration come with the programme. It calls :func:`mtmetrology.design.samba.plan_samba`
with the arguments ``mtm samba plan`` uses, so the printed command rewrites the same
programme. Run it on its own::

    python examples/samba_planning.py [OUT]
"""

from __future__ import annotations

import mtmetrology.design.report  # noqa: F401  (registers the plan renderer)
from mtmetrology.design.accessibility import AccessibilityRule
from mtmetrology.design.inputs import axis_grid, grid_indexations, load_ball_grid
from mtmetrology.design.samba import plan_samba
from mtmetrology.io.tables import write_csv_table
from mtmetrology.kinematics.machine import Machine
from mtmetrology.report.demo import DemoContext
from mtmetrology.report.results import add_result
from mtmetrology.units import to_internal

PRESET = "five-axis-wcbxfzyst"
GRID_YAML = """kind: samba-ball-grid
x_mm: [-80, 0, 80]
y_mm: [-40, 40]
stems_mm: [75, 150]
"""
B_GRID, C_GRID = "-60:60:20", "0:330:30"
SIGMA_UM = 1.0


def main(ctx: DemoContext) -> None:
    ctx.rule("Planning a SAMBA test by DETMAX")
    machine = Machine.load(PRESET, "13")
    ctx.write_text(GRID_YAML, "planning", "ball-grid.yaml")
    grid = load_ball_grid(ctx.path("planning", "ball-grid.yaml"))
    rule = AccessibilityRule()
    pairs = grid_indexations(axis_grid(B_GRID, "--b-grid"), axis_grid(C_GRID, "--c-grid"))
    with ctx.step("DETMAX: 2 balls of 12 candidates, then the indexations (D criterion)"):
        design = plan_samba(
            machine,
            pairs,
            candidates=grid.candidates(rule.table_z_mm),
            n_balls=2,
            k=3.0,
            criterion="D",
            bar=grid.scale_bar,
            rule=rule,
            sigma_mm=float(to_internal(SIGMA_UM, "µm")),
            starts=1,
            seed=ctx.seed,
        )
    header, rows = design.programme.table()
    write_csv_table(ctx.path("planning", "programme.csv"), header, rows)
    doc = design.to_dict()
    ctx.write_json(doc, "planning", "plan.json")
    ctx.report.section(
        "Planning a SAMBA test",
        "DETMAX (Mitchell 1974) chose two master balls from twelve candidates and then the "
        "(B, C) indexations, maximising det(JᵀJ) of the column-scaled identification "
        "Jacobian; the predicted standard uncertainties are for 1 µm probing noise.",
    )
    add_result(ctx.report, design)
    ctx.command(
        "the plan",
        "samba", "plan", "--machine", PRESET, "--model", "13",
        "--balls-from", ctx.shown("planning", "ball-grid.yaml"), "--n-balls", "2",
        "--k", "3", "--criterion", "D", "--starts", "1", "--seed", str(ctx.seed),
        "--b-grid", B_GRID, "--c-grid", C_GRID, "--sigma-um", f"{SIGMA_UM:g}",
        "-o", ctx.shown("planning", "programme.csv"),
    )  # fmt: skip
    ctx.summary.append(
        f"planning: balls {', '.join(b['id'] for b in doc['balls'])} of 12 candidates, "
        f"{doc['n_indexations']} indexations, {doc['n_measurements']} probings "
        f"({doc['duration_h']:.1f} h); rank {doc['rank']}/{doc['n_unknowns']}, "
        f"scaled condition number {doc['condition_scaled']:.0f}"
    )


if __name__ == "__main__":
    from mtmetrology.report.demo import run_example

    run_example(main, "samba_planning")
