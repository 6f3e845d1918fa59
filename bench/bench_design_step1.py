"""Benchmark: DETMAX step 1 (ball choice) with two styli.

The seed-004 candidate grid (5 × 4 pallet positions × 5 stems = 100 balls), 450 candidate
(B, C) indexations (25 × 18), 13-parameter model + E_AY1 (one stylus confounds E_AY1 ~
E_YY1), styli (0, 0, −150) and (0, 0, −200) mm, 4 balls, O2 criterion.

Contenders:
* ours: step 1 with both styli (``choose_balls(tools=...)``: the per-candidate Gram blocks
  of every candidate's two-stylus rows, then one DETMAX run assembling trial designs
  from the blocks in one batched call);
* ours: the same with one stylus (what the second stylus costs);
* loop: the naive version, each trial ball set scored by the Jacobian of its whole
  two-stylus programme (``programme_problem`` + SVD); timed on 1 trial, scaled to the
  trials of the run (candidates scored per exchange × exchanges);
* floor: the nominal Jacobian of all candidate rows with both styli in one call (what any
  scoring of the candidates must evaluate once).

BLAS single-threaded, as in the other design benchmarks.

Run: ``python bench/bench_design_step1.py``
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from harness import Benchmark  # noqa: E402
from mtmetrology.design.accessibility import AccessibilityRule  # noqa: E402
from mtmetrology.design.inputs import (  # noqa: E402
    SEED004_GRID,
    ScaleBarPlacement,
    default_indexations,
)
from mtmetrology.design.programme import (  # noqa: E402
    ProgrammeRows,
    accessible_all,
    approach_senses,
    fixed_programme_rows,
    nominal_jacobian,
    per_tool,
    programme_problem,
)
from mtmetrology.design.samba import choose_balls  # noqa: E402
from mtmetrology.kinematics import Machine  # noqa: E402

STYLI = np.array([(0.0, 0.0, -150.0), (0.0, 0.0, -200.0)])


def programme_jacobian(machine, ids, centres, pairs, mask, members, bar):
    """Jacobian of the two-stylus programme of one ball set (fixed rows, each ball at
    B = C = 0 and wherever both styli reach it)."""
    senses = approach_senses(len(pairs))
    parts = [fixed_programme_rows(bar, [ids[i] for i in members])]
    for i in members:
        ok = np.flatnonzero(mask[:, i])
        parts.append(
            ProgrammeRows([ids[i]] * ok.size, pairs[ok, 0], pairs[ok, 1], np.zeros(ok.size),
                          senses[ok, 0], senses[ok, 1])
        )  # fmt: skip
    rows = per_tool(ProgrammeRows.concat(parts), len(STYLI))
    cen = {ids[i]: centres[i] for i in members} | dict(zip(bar.ends, bar.centres_mm, strict=True))
    return nominal_jacobian(programme_problem(machine, rows, cen, bar, 0.001, STYLI))


def main() -> None:
    base = Machine.load("five-axis-wcbxfzyst", "13")
    m = base.with_parameters([*base.parameter_names, "E_AY1"])
    ids, centres = SEED004_GRID.candidates()
    pairs = default_indexations()
    bar, rule = ScaleBarPlacement(), AccessibilityRule()
    mask = accessible_all(m, rule, centres, pairs, STYLI, obstacles=False)
    kw = {"criterion": "O2", "starts": 1, "seed": 0}

    def ours_two():
        return choose_balls(m, ids, centres, 4, pairs, tools=STYLI, **kw)

    chosen, _, search = ours_two()
    exchanges = search.best.exchanges + 1  # the last, refused exchange is scored too
    trials = exchanges * (len(ids) - 4 + 5)  # add: every outside candidate; remove: 5
    members = [ids.index(b) for b in chosen]

    def naive_trial():
        j = programme_jacobian(m, ids, centres, pairs, mask, members, bar)
        s = np.linalg.svd(j / np.linalg.norm(j, axis=0), compute_uv=False)
        return s[-1] / s[0]

    everything = list(range(len(ids)))
    b = Benchmark(
        "design_step1_styli",
        f"DETMAX step 1, 13 parameters + E_AY1, two styli: {len(ids)} candidate balls x "
        f"{len(pairs)} indexations, 4 balls, O2, one start",
    )
    b.time("ours: step 1, two styli", "ours", ours_two)
    b.time(
        "ours: step 1, one stylus",
        "ours",
        lambda: choose_balls(m, ids, centres, 4, pairs, **kw),
    )
    b.time(
        "naive: programme Jacobian + SVD per trial set",
        "loop",
        naive_trial,
        scale=trials,
        note=f"1 trial x {trials}",
    )
    b.time(
        "floor: Jacobian of all candidate rows, both styli",
        "floor",
        lambda: programme_jacobian(m, ids, centres, pairs, mask, everything, bar),
    )
    b.notes += [
        f"chosen balls {', '.join(chosen)}; O2 {search.best.start_value:.4g} -> "
        f"{search.best.value:.4g} in {search.best.exchanges} exchanges ({search.best.message})",
        f"{int(mask.sum())} accessible (ball, indexation) pairs for both styli",
    ]
    b.report()


if __name__ == "__main__":
    main()
