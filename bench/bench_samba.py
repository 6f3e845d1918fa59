"""Benchmark: uncertainty of a SAMBA identification by GUF and by Monte Carlo re-solving it.

Problem (examples/samba): the 13-parameter model of the five-axis preset, 4 master balls
and a scale bar, 111 ball-centre indications (25 (B, C) pairs, spindle indexing), tool
estimated: 34 unknowns, 334 inputs (333 readings + the bar length), noise 0.5 µm.  Sepahi
Boroujeni (2021) §5 needed 24 h for the adaptive MCM (10⁵ trials) and minutes for the GUF.

Contenders
----------
ours      ``identification_mcm``: 10⁵ trials, each re-solved to convergence by the batched
          chord iteration (exact residuals of all (trial, indication) pairs in one call of
          the kinematic engine), in-process and on 2 processes (a cold pool per run);
          ``identification_guf``; and two phases of the MCM: drawing and solving the
          chunks (the part the processes share out) and starting the pool.
baseline  the Monte Carlo of the linearised model ``x̂ + C (z − z₀)`` in vectorised numpy
          (draws and one product per chunk, no re-solve).
loop      a per-trial ``scipy.optimize.least_squares`` (method "lm", analytic Jacobian,
          started at the solution) on 100 trials, scaled to 10⁵.
floor     drawing the random inputs (10⁵ × 334 standard normals).

In-process, 2-process, baseline, floor and phases run in alternation, 5 repeats each; the
notes give the serial fraction (Amdahl) and the load average.  ``--before`` adds both MCM
runs without the BLAS thread limits (an A/B of the change in one run).

Then the 84-coefficient model (4 balls, 17 non-linear (B, C) pairs with spindle
indexing, 105 unknowns) with 10⁴ trials.

Targets: MCM 10⁵ trials < 10 s on 2 cores (stretch 5 s), in-process within 4× of the
draw floor, 2 processes faster than in-process; GUF < 0.1 s.
Run: ``python bench/bench_samba.py [--before]``.
"""

from __future__ import annotations

import os
import pickle
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.optimize

from harness import Benchmark, patched
from mtmetrology._backend import one_thread
from mtmetrology.identification import identification_guf, identification_mcm
from mtmetrology.identification import uncertainty as identification_uncertainty
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import ParameterSet
from mtmetrology.rng import chunk_generators
from mtmetrology.samba import (
    ProbingProgramme,
    calibrate,
    indication_inputs,
    load_artefact,
    load_balls,
    read_poses,
    simulate_records,
    uncertainty_model,
)
from mtmetrology.samba.records import read_records
from mtmetrology.uncertainty import executors
from mtmetrology.uncertainty.executors import ProcessPoolExecutor
from mtmetrology.units import to_internal

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "samba"
NOISE = float(to_internal(0.5, "µm"))
LOOP_TRIALS = 100


def calibrated(machine, truth, programme, tmp: Path):
    art = load_artefact(EXAMPLES / "artefact.yaml")
    balls = load_balls(EXAMPLES / "balls.yaml").centres()
    simulate_records(machine, truth, balls, programme, art, noise=NOISE, seed=1).write(tmp)
    rec = read_records(tmp, machine, art)
    cal = calibrate(machine, rec, art, sigma=NOISE, estimate_tool=True)
    return cal, indication_inputs(cal.problem, noise=NOISE)


def guf_of(cal, inputs):
    return identification_guf(uncertainty_model(cal), inputs)


def mcm_of(cal, inputs, **options):
    return identification_mcm(uncertainty_model(cal), inputs, **options)


def scipy_trial(cal, z):
    """One Monte Carlo trial the straightforward way: a new problem, scipy's solver."""
    trial = cal.problem.with_inputs(z)
    res = scipy.optimize.least_squares(
        lambda x: trial.evaluate(x, jacobian=False)[0],
        cal.identification.estimate,
        jac=lambda x: trial.evaluate(x)[1],
        method="lm",
        xtol=1e-12,
    )
    return res.x[cal.parameter_indices()]


def linearised(cal, inputs, trials, chunk=2_000):
    """The numpy baseline: the Monte Carlo of the linearised model ``x̂ + C (z − z₀)``
    (draws and one product per chunk, no re-solve): what re-solving adds to it."""
    model = uncertainty_model(cal)
    rows = model.all_sensitivities[model.index] / model.scales[:, None]
    y0 = model.x0[model.index] / model.scales
    out = np.empty((trials, rows.shape[0]))
    with one_thread():  # as ours: threads do not pay on (2000, 334) @ (334, 13)
        for k, g in enumerate(chunk_generators(1, -(-trials // chunk))):
            z = inputs.sample(g, min(chunk, trials - k * chunk))
            out[k * chunk : k * chunk + z.shape[0]] = y0 + (z - model.z0) @ rows.T
    return out.mean(axis=0), np.cov(out, rowvar=False)


class Traced:
    """The model with each chunk's wall-clock span and CPU seconds appended to ``log`` (one
    line per chunk, from whichever process runs it): where a run's time goes, measured
    inside the run."""

    def __init__(self, model, log: Path):
        self.model, self.log = model, log
        self.output_names, self.output_units = model.output_names, model.output_units

    def __call__(self, z):
        start, cpu = time.time(), time.process_time()
        y = self.model(z)
        with open(self.log, "a") as f:
            f.write(f"{start} {time.time()} {time.process_time() - cpu}\n")
        return y


def phases_of(cal, inputs, trials, executor, log: Path, record: list):
    """One MCM run (model built inside, as ``mcm_of``); appends (set-up, chunks, wind-down,
    cores) to ``record``: seconds before the first chunk starts (model set-up, tasks,
    pool start, pickling), from the first chunk's start to the last one's end, after it
    (results back, statistics), and the cores the chunks got (their CPU seconds over the
    chunks' span; the draws between chunks are left out)."""
    log.write_text("")
    start = time.time()
    identification_mcm(
        Traced(uncertainty_model(cal), log), inputs, trials=trials, seed=1, executor=executor
    )
    end = time.time()
    spans = np.loadtxt(log, ndmin=2)
    first, last = spans[:, 0].min(), spans[:, 1].max()
    record.append((first - start, last - first, end - last, spans[:, 2].sum() / (last - first)))


def many_blas_threads(function):
    """``function`` as before this change: no BLAS thread limit in the model or workers."""
    import contextlib

    return patched(
        identification_uncertainty,
        "one_thread",
        contextlib.nullcontext,
        patched(executors, "pin_one_thread", lambda: None, function),
    )


def amdahl(bench, phases, shipped_bytes):
    """Notes: per-phase medians of both runs, the serial fraction and the 2-process bound."""
    med = {k: np.median(np.array(v), axis=0) for k, v in phases.items()}
    (s1, c1, w1, k1), (s2, c2, w2, k2) = med["in-process"], med["2 processes"]
    s3 = med["2 processes, warm pool"][0]
    total1 = s1 + c1 + w1
    bound = s2 + c1 / 2 + w2
    for name, (su, ch, wd, cores) in med.items():
        bench.notes.append(
            f"phases, {name} (medians of the timed runs): set-up {su:.3f} s, chunks "
            f"{ch:.3f} s, wind-down {wd:.3f} s; the chunks got {cores:.2f} cores"
        )
    bench.notes.append(
        f"Amdahl: serial fraction in-process {(s1 + w1) / total1:.1%} (set-up and "
        f"statistics); the 2-process run's set-up adds the pool start ({s2 - s3:.2f} s, "
        f"cold minus warm set-up) and {shipped_bytes / 1e6:.1f} MB of pickled model and "
        f"inputs; with 2 free cores its "
        f"chunks would take {c1 / 2:.2f} s and the run {bound:.2f} s "
        f"(speed-up {total1 / bound:.2f} over in-process); measured: its chunks took "
        f"{c2:.2f} s on {k2:.2f} cores against {c1:.2f} s on {k1:.2f} in-process"
    )
    bench.notes.append(
        f"load average at the end: {', '.join(f'{v:.1f}' for v in os.getloadavg())} on "
        f"{os.cpu_count()} cores; the kernel shares the cores between sessions "
        f"(sched_autogroup_enabled = {_autogroup()}): while other sessions keep the cores "
        "busy, a session's 2 workers get the CPU time its 1 process would get"
    )


def _autogroup() -> str:
    try:
        return Path("/proc/sys/kernel/sched_autogroup_enabled").read_text().strip()
    except OSError:
        return "unknown"


def run(name, cal, inputs, trials, bench_guf=True, before=False):
    bench = Benchmark(
        name,
        f"{cal.machine.n_params} parameters, "
        f"{len(cal.identification.names)} unknowns, "
        f"{len(cal.records)} indications, {trials:,} trials",
    )
    if bench_guf:
        bench.time("identification_guf", "ours", lambda: guf_of(cal, inputs), repeats=20)

    log = Path(tempfile.mkdtemp()) / "chunks.log"
    phases = {"in-process": [], "2 processes": [], "2 processes, warm pool": []}
    warm = ProcessPoolExecutor(2)

    def inproc():
        return phases_of(cal, inputs, trials, None, log, phases["in-process"])

    def two():
        return phases_of(cal, inputs, trials, "processes:2", log, phases["2 processes"])

    def two_warm():
        return phases_of(cal, inputs, trials, warm, log, phases["2 processes, warm pool"])

    rng = np.random.default_rng(3)
    contenders = [
        (f"identification_mcm {trials:,}, in-process", "ours", inproc),
        (f"identification_mcm {trials:,}, 2 processes", "ours", two, "cold: starts its pool"),
        (f"identification_mcm {trials:,}, 2 warm processes", "ours", two_warm, "pool reused"),
        (
            f"linearised model {trials:,} (numpy)",
            "baseline",
            lambda: linearised(cal, inputs, trials),
        ),
        (
            f"draw the inputs ({trials:,} x {inputs.estimate.size})",
            "floor",
            lambda: rng.standard_normal((trials, inputs.estimate.size)),
        ),
    ]
    if before:
        unlimited = [
            lambda: mcm_of(cal, inputs, trials=trials, seed=1),
            lambda: mcm_of(cal, inputs, trials=trials, seed=1, executor="processes:2"),
        ]
        contenders += [
            (f"before: mcm {trials:,}, {where}", "ours", many_blas_threads(f), "BLAS unlimited")
            for where, f in zip(("in-process", "2 processes"), unlimited, strict=True)
        ]
    with warm:
        bench.time_interleaved(contenders, repeats=5)
    for runs in phases.values():
        del runs[0]  # the warm-up run
    z = inputs.sample(np.random.default_rng(2), LOOP_TRIALS)
    bench.time(
        f"scipy least_squares loop ({LOOP_TRIALS} trials, scaled)",
        "loop",
        lambda: [scipy_trial(cal, zk) for zk in z],
        repeats=5,
        scale=trials / LOOP_TRIALS,
    )
    # the same numbers on both executors and against the scipy loop
    a = mcm_of(cal, inputs, trials=4000, seed=7)
    b = mcm_of(cal, inputs, trials=4000, seed=7, executor="processes:2")
    assert np.array_equal(a.estimate, b.estimate), "executors must agree"
    amdahl(bench, phases, 4 * len(pickle.dumps((uncertainty_model(cal), inputs))))
    bench.notes.append(
        "in-process and 2-process results are bit-identical for a seed; GUF/MCM validation "
        "is in tests/samba/test_uncertainty.py"
    )
    bench.notes.append(
        "in-process, 2-process, baseline and floor are timed in alternation (harness "
        "time_interleaved), so a change of load hits them alike; the MCM runs log each "
        "chunk's span (one line per chunk) for the phases"
    )
    return bench


def main() -> None:
    tmp = Path(tempfile.mkdtemp())
    m13 = Machine.load("five-axis-wcbxfzyst", "13")
    truth = ParameterSet.load(EXAMPLES / "truth.json", m13).vector_for(m13)
    cal, inputs = calibrated(m13, truth, read_poses(EXAMPLES / "poses.csv"), tmp / "r13.csv")
    bench = run("samba_13", cal, inputs, 100_000, before="--before" in sys.argv)
    bench.target("identification_guf", 0.1, text="GUF under 0.1 s")
    bench.target(
        "identification_mcm 100,000, in-process",
        4.0,
        relative_to="draw the inputs (100,000 x 334)",
        text="within 4x of the draw floor",
    )
    bench.target(
        "identification_mcm 100,000, 2 processes",
        1.0,
        relative_to="identification_mcm 100,000, in-process",
        text="2 processes faster than in-process",
    )
    bench.target(
        "identification_mcm 100,000, 2 processes",
        10.0,
        text="10^5 trials under 10 s on 2 cores (stretch 5 s)",
    )
    bench.report()

    m84 = Machine.load("five-axis-wcbxfzyst", "84")
    rng = np.random.default_rng(0)
    cands = [(b, c) for b in range(-90, 91, 15) for c in range(0, 360, 15) if (b, c) != (0, 0)]
    pairs = sorted([(0, 0)] + [cands[i] for i in rng.choice(len(cands), 16, replace=False)])
    rows = [(b, 0.0, 0.0, 0.0) for b in "1234"]
    rows += [(b, bb, cc, 0.0) for bb, cc in ((0, 0), (0, 90)) for b in ("SB1", "SB2")]
    rows += [("1", 0.0, 0.0, s) for s in (90.0, 180.0, 270.0)]
    rows += [(b, bb, cc, 0.0) for bb, cc in pairs for b in "1234"]
    cols = list(zip(*rows, strict=True))
    prog = ProbingProgramme(tuple(cols[0]), *(np.array(c, dtype=float) for c in cols[1:]))
    cal84, inputs84 = calibrated(m84, None, prog, tmp / "r84.csv")
    bench84 = run("samba_84", cal84, inputs84, 10_000)
    bench84.report()


if __name__ == "__main__":
    main()
