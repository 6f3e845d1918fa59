"""Benchmark: DETMAX step 2 for the 84-coefficient SAMBA model.

4 master balls (the identifiability check's layout), 450 candidate (B, C) indexations
(25 x 18 grid), k = 5: M = 5 x ceil(99/3) = 165 indexations, 105 unknowns, D criterion.

Contenders:
* ours: one DETMAX run (rank-r determinant lemma / Woodbury scores of all candidates);
* ours: 8 random starts on a 2-process pool;
* baseline: the same exchange scoring each trial design by a fresh Cholesky
  factorisation of its 105 x 105 information matrix (batched numpy, no updates),
  one exchange timed, scaled to the run's number of exchanges;
* loop: the naive version, a fresh SVD of the trial design's Jacobian (about 2000 x 105)
  for every candidate of every exchange; timed on 1 trial in 10 of one exchange and
  scaled to the run (x 10 x exchanges);
* floor: the one product X·F⁻¹ over all candidate rows that any exchange scoring needs,
  times the number of exchanges.

Target: one run under 5 s.

BLAS runs single-threaded (set below, before numpy loads) so that the 2-process pool does
not oversubscribe the 2 cores; every contender runs under the same setting.

Run: ``python bench/bench_design.py``
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from harness import Benchmark  # noqa: E402
from mtmetrology.design.accessibility import AccessibilityRule  # noqa: E402
from mtmetrology.design.counts import indexation_count  # noqa: E402
from mtmetrology.design.detmax import BlockInformation, detmax, detmax_run  # noqa: E402
from mtmetrology.design.inputs import ScaleBarPlacement, default_indexations  # noqa: E402
from mtmetrology.design.programme import evaluate_programme  # noqa: E402
from mtmetrology.design.samba import candidate_blocks  # noqa: E402
from mtmetrology.kinematics import Machine  # noqa: E402
from mtmetrology.uncertainty.executors import ProcessPoolExecutor  # noqa: E402

IDS = ["1", "2", "3", "4"]
CENTRES = np.array(
    [(-80.0, -40.0, 100.0), (80.0, -40.0, 150.0), (80.0, 120.0, 75.0), (-80.0, 120.0, 175.0)]
)


def naive_exchange(space, members, fixed_rows, every=1):
    """One add + remove step, each trial scored by the SVD of its Jacobian (every
    ``every``-th trial only, for timing)."""

    def value(idx):
        j = np.vstack([fixed_rows, space.blocks[idx].reshape(-1, space.n_unknowns)])
        s = np.linalg.svd(j, compute_uv=False)
        return 2.0 * np.sum(np.log(s))

    outside = np.setdiff1d(np.arange(space.n_candidates), members)[::every]
    add = outside[np.argmax([value(np.r_[members, c]) for c in outside])]
    plus = np.r_[members, add]
    return plus[np.argmax([value(plus[plus != c]) for c in plus[::every]])]


def cholesky_exchange(space: BlockInformation, state):
    """One add + remove step, each trial's log det from a fresh (batched) Cholesky."""
    members = np.flatnonzero(state.members)
    outside = np.flatnonzero(~state.members)

    def logdets(sign, idx):
        x = space.blocks[idx]
        trial = state.info[None] + sign * (np.swapaxes(x, 1, 2) @ x)
        return 2.0 * np.log(np.diagonal(np.linalg.cholesky(trial), axis1=1, axis2=2)).sum(1)

    add = outside[np.argmax(logdets(+1, outside))]
    return members[np.argmax(logdets(-1, members))], add


def main() -> None:
    m = Machine.load("five-axis-wcbxfzyst", "84")
    pairs = default_indexations()
    size = indexation_count(5, m.n_params, len(IDS), rule="indexations")  # M = 165 (RESULTS)
    fixed, blocks, counts, _, usable, n_fixed = candidate_blocks(
        m, IDS, CENTRES, pairs, ScaleBarPlacement(), AccessibilityRule(), 0.001
    )
    space = BlockInformation(fixed, blocks[usable], "D", n_fixed, counts[usable])
    lam, vec = np.linalg.eigh(space.fixed_info)  # rows whose Gram is the fixed information
    fixed_rows = np.sqrt(np.clip(lam, 0.0, None))[:, None] * vec.T
    start = np.sort(np.random.default_rng(0).choice(space.n_candidates, size, replace=False))
    run = detmax_run(space, start)
    exchanges = run.exchanges + 1  # the last, refused exchange is scored too

    b = Benchmark(
        "design_detmax",
        f"DETMAX step 2, 84-coefficient model: 4 balls, {space.n_candidates} accessible "
        f"candidates of {len(pairs)}, M = {size} (k = 5), {space.n_unknowns} unknowns, D",
    )
    b.time("ours: one DETMAX run", "ours", lambda: detmax_run(space, start))
    multi = []
    with ProcessPoolExecutor(2) as pool:
        b.time(
            "ours: 8 starts on 2 processes",
            "ours",
            lambda: multi.append(detmax(space, size, starts=8, seed=1, executor=pool)),
        )
    state = space.start(start)
    b.time(
        "fresh Cholesky per trial (batched)",
        "baseline",
        lambda: cholesky_exchange(space, state),
        scale=exchanges,
        note=f"1 exchange x {exchanges}",
    )
    b.time(
        "naive: fresh SVD per trial design",
        "loop",
        lambda: naive_exchange(space, start, fixed_rows, every=10),
        scale=10 * exchanges,
        note=f"1 trial in 10 of 1 exchange x 10 x {exchanges}",
    )
    flat = space.blocks.reshape(-1, space.n_unknowns)
    b.time(
        "floor: X F^-1 over all candidate rows",
        "floor",
        lambda: flat @ state.inverse,
        scale=exchanges,
        note=f"x {exchanges}",
    )
    prog = evaluate_programme(m, IDS, CENTRES, pairs[usable[run.members]])
    b.notes += [
        f"one run: D (log det, reference scaling) {run.start_value:.3f} -> {run.value:.3f} "
        f"in {run.exchanges} exchanges ({run.message})",
        f"final design: rank {prog.report.rank}/{prog.report.n_unknowns}, condition "
        f"{prog.report.condition_scaled:.4g} (columns scaled), {prog.n_measurements} "
        f"measurements",
        "8 starts: final D " + ", ".join(f"{r.value:.3f}" for r in multi[-1].runs),
    ]
    b.target("ours: one DETMAX run", 5.0, text="issue 13: one run under 5 s")
    b.report()


if __name__ == "__main__":
    main()
