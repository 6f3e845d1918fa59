"""Study: Alami Mchichi (2018) Table 5.3 with ``mtm samba compare-plans`` on all 450 candidates.

84-parameter model, the four laboratory balls (nested: 3 and 4 balls), k = 2, 3, 4, 5, 10,
criterion O2, three DETMAX starts: Cond_N, Cond_n start → end, the improvement and the
duration of each strategy beside the source's row. Also times each strategy (min and
median over the sweep).

Measured (2 cores shared, seed 1, k = 2 and 5): end 560 / 424 (3 balls) and 518 / 379
(4 balls) against the table's 505 / 386 and 469 / 369; improvement 57.3 / 61.3 / 65.5 /
55.0 % against 45.9 / 40.0 / 55.7 / 46.2 %; Cond_N 991 (3 balls) and 809 (4 balls) against
588 and 482 (the laboratory balls; at the balls step 1 chooses, Cond_N is 525 and 471:
tests/design/test_table_a1_condition.py); 18–52 s per strategy.

Not run by ``make bench`` (a study, not a speed benchmark): ``python
bench/study_design_compare.py [k ...]`` (about 20 s per strategy on one core).
"""

from __future__ import annotations

import os
import statistics
import sys
import time

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402

from mtmetrology.design.compare import compare_strategies  # noqa: E402
from mtmetrology.design.inputs import default_indexations  # noqa: E402
from mtmetrology.kinematics import Machine  # noqa: E402

IDS = ["1", "2", "3", "4"]
CENTRES = np.array(
    [(-80.0, -40.0, 100.0), (80.0, -40.0, 150.0), (80.0, 120.0, 75.0), (-80.0, 120.0, 175.0)]
)
#: Table 5.3: (balls, k) -> (Cond_N, start, end, hours).
TABLE_5_3 = {
    (3, 2): (588, 934, 505, 1.6),
    (3, 3): (588, 682, 395, 2.3),
    (3, 4): (588, 615, 373, 3.1),
    (3, 5): (588, 643, 386, 3.8),
    (3, 10): (588, 593, 377, 7.4),
    (4, 2): (482, 1058, 469, 1.6),
    (4, 3): (482, 819, 393, 2.4),
    (4, 4): (482, 743, 382, 3.1),
    (4, 5): (482, 686, 369, 3.9),
    (4, 10): (482, 564, 371, 7.6),
}


def main(ks) -> None:
    m = Machine.load("five-axis-wcbxfzyst", "84")
    pairs = default_indexations()
    times = []
    print("strategy   Cond_N (src)  start (src)  end (src)  improvement (src)  hours (src)")
    for n in (3, 4):
        for k in ks:
            t0 = time.perf_counter()
            (s,) = compare_strategies(
                m, pairs, (IDS, CENTRES), n_balls=(n,), ks=(k,), starts=3, seed=1
            ).strategies
            times.append(time.perf_counter() - t0)
            cn, st, en, h = TABLE_5_3[(n, k)]
            print(
                f"{s.name:<10} {s.condition_all:6.0f} ({cn})  {s.condition_start:6.0f} ({st})  "
                f"{s.condition_end:5.0f} ({en})  {100 * s.improvement:5.1f} % "
                f"({100 * (st - en) / st:.1f} %)  {s.duration_h:4.1f} ({h})"
            )
    print(f"seconds per strategy: min {min(times):.1f}, median {statistics.median(times):.1f}")


if __name__ == "__main__":
    main([float(a) for a in sys.argv[1:]] or [2.0, 3.0, 4.0, 5.0, 10.0])
